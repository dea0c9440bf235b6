"""The report's goals section (issue 15): scores under the chosen preset by NRNS difficulty and
goal kind, and how the image goals were localised."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from navbench.nav.presets import PRESETS


#: Goal images drawn per level in the report.
GOAL_IMAGES_PER_LEVEL = 4
#: ``goal_status`` of ``--map online`` rows: the last goal match (navbench.pipeline.stages.online).
ONLINE_PREFIX = "online-"


def _online_goals(page: Any, rows) -> None:
    """``--map online`` (no prior map): per level and conditions, the last goal match of each
    episode (matched / weak / ambiguous / none), the episodes the agent stopped and the median
    distance of the last matched goal to the true one."""
    shared, settings = split_conditions(rows.get("conditions", ["unrecorded"] * len(rows)))
    rows = rows.assign(match=rows["goal_status"].astype(str).str.removeprefix(ONLINE_PREFIX), setting=settings)
    keys = ["level", "setting"]
    counts = (rows.groupby([*keys, "match"]).size().unstack(fill_value=0)
              .reindex(columns=["matched", "weak", "ambiguous", "none"], fill_value=0))
    counts["stopped"] = rows.assign(s=rows["end_reason"].eq("reached")).groupby(keys)["s"].sum()
    counts["median error (m)"] = rows.groupby(keys)["goal_err_m"].median()
    page.table(counts, "goal_online", "Image goals in an unknown house (--map online; the conditions name "
               "the sensing model): the agent's last goal match per episode, the episodes it stopped "
               f"by its own decision and the median distance of its last matched goal to the true one{_under(shared)}",
               index=True, digits=3)


def difficulty_pivot(table) -> tuple["pandas.DataFrame", str]:
    """:func:`~navbench.results.score.difficulty_table` as one row per (level, estimator, noise,
    goal, setting) and one column per difficulty, each cell ``"SR [lo, hi] / SPL"``; ``setting``
    holds the conditions in which the rows differ (a map mode, an ablation), and the returned
    string the conditions they share (left out of every row; ``""`` when none is recorded).
    A single setting drops the column; ``level = "all"`` holds the pooled rows."""
    import pandas as pd

    labels = list(table["conditions"]) if "conditions" in table.columns else ["unrecorded"] * len(table)
    shared, settings = split_conditions(labels)
    t = table.assign(setting=settings)
    present = set(t["difficulty"])
    order = [d for d in ("easy", "medium", "hard", "other", "all") if d in present]
    keys = ["level", "estimator", "noise", "goal", "setting"]
    rows = []
    for key, g in t.groupby(keys, sort=False):
        rec = dict(zip(keys, key))
        by = {r.difficulty: r for r in g.itertuples()}
        for d in order:
            r = by.get(d)
            rec[d] = "–" if r is None else (f"{r.success_rate:.2f} [{r.success_rate_ci_low:.2f}, "
                                            f"{r.success_rate_ci_high:.2f}] / {r.spl:.2f}")
        rec["episodes"] = int(by["all"].episodes)  # difficulty_table pools every group as "all"
        rows.append(rec)
    out = pd.DataFrame(rows, columns=[*keys, *order, "episodes"])
    if out["setting"].nunique() <= 1:
        out = out.drop(columns="setting")
    return out, shared


def _under(shared: str) -> str:
    """A caption's clause naming the conditions every row shares (:func:`split_conditions`)."""
    if not shared:
        return ""
    return "; every row under " + ("the default simulator conditions" if shared == "defaults" else shared)


def split_conditions(labels) -> tuple[str, list[str]]:
    """Conditions labels (``score.conditions_label``) as the part every label shares (the
    conditions at their defaults left out, as :func:`~navbench.results.score.short_conditions`:
    ``"defaults"`` when all are; ``""`` when nothing is shared or recorded) and each label's own
    rest (``"–"`` when none): a narrow ``setting`` column, the shared part said once."""
    from navbench.results.score import short_conditions

    split = [short_conditions(c).split(", ") for c in labels]
    common = [p for p in split[0] if all(p in q for q in split)] if split else []
    shared = ", ".join(common)
    return ("" if shared == "unrecorded" else shared,
            [", ".join(p for p in q if p not in common) or "–" for q in split])


def section_goals(page: Any, episodes, levels_dir: Path | None = None, tasks=None,
                  load_trajectory=None, load_map=None) -> None:
    """Scores by difficulty and goal (:func:`navbench.results.score.difficulty_table`)
    and, where image goals were run, the goal-localisation outcomes per level and the first
    goal images of each level (rendered again from the level file in ``levels_dir``, the task's
    target in ``tasks`` (the database's tasks frame) and the stored heading: byte for byte the
    image the agent was given, at the ``half`` camera). Online episodes (``--map online``) get
    top views per level and conditions (:mod:`navbench.report.topviews`: their
    trajectories through ``load_trajectory``, the grid of their explored cells through
    ``load_map``, as :func:`navbench.report.build.build_report`'s)."""
    from navbench.results.score import difficulty_table

    page.h2("Goals and difficulty (scoring preset)", "goals")
    if episodes is None or episodes.empty:
        page.note("No navigation episodes stored yet.")
        return
    name = episodes.attrs.get("preset", "paper")
    page.p(f"Scoring preset '{name}': {PRESETS[name].description}. SoftSPL: habitat-lab's "
           "max(0, 1 - d_T / d_0) * d_0 / max(p, d_0) with the final geodesic distance d_T; final "
           "distance: the preset's d_T (mean, m). Difficulty: NRNS bands of the exact geodesic "
           "start-goal distance (easy 1.5-3 m, medium 3-5 m, hard 5-10 m; 'other' outside them).")
    table = difficulty_table(episodes)
    pivot, common = difficulty_pivot(table)
    where = _under(common)
    several = pivot.loc[pivot["level"] != "all", "level"].nunique() > 1
    page.table(table, "by_difficulty",
               f"Success rate [95% exact interval] / SPL by difficulty, scored under the '{name}' "
               f"preset, {'pooled over levels' if several else 'one level'}{where}; the CSV adds "
               "SoftSPL, the final distance and the level rows",
               display=pivot[pivot["level"] == "all"].drop(columns="level") if several
               else pivot[pivot["level"] != "all"])
    if several:
        page.table(table[table["level"] != "all"], "by_difficulty_levels",
                   "The same per level", display=pivot[pivot["level"] != "all"])
    if "goal_status" not in episodes.columns or episodes["goal"].eq("image").sum() == 0:
        return
    img = episodes[episodes["goal"] == "image"]
    online = img["goal_status"].astype(str).str.startswith(ONLINE_PREFIX)
    known = img[~online]
    if not known.empty:
        counts = (known.groupby(["level", "goal_status"]).size().unstack(fill_value=0)
                  .reindex(columns=["ok", "ambiguous", "failed"], fill_value=0))
        counts["median error (m)"] = known.groupby("level")["goal_err_m"].median()
        page.table(counts, "goal_localization", "Image goals: localisation of the goal image in the "
                   "map per episode (ok / ambiguous / failed) and the median distance of the found goal "
                   "to the true one", index=True, digits=3)
    if online.any():
        _online_goals(page, img[online])
        from navbench.report.topviews import section_online_topviews

        section_online_topviews(page, img[online], levels_dir, load_trajectory, load_map)
    if levels_dir is None or tasks is None or tasks.empty or "goal_heading" not in img.columns:
        return
    # an online episode's goal image is drawn under its top view when there is one
    strip = known if load_trajectory is not None else img
    for level, g in strip.dropna(subset=["goal_heading"]).groupby("level", sort=True):
        path = Path(levels_dir) / f"{level}.json"
        if not path.is_file():
            continue
        first = g.drop_duplicates(["task_set_key", "task_id"]).head(GOAL_IMAGES_PER_LEVEL)
        page.figure(lambda fig, first=first, path=path: _draw_goals(fig, first, path, tasks),
                    f"{level}: goal images (task, localisation status, error of the found goal)",
                    (2.6 * len(first), 2.4))


def _draw_goals(fig, rows, level_path: Path, tasks) -> None:
    """Each row's goal image (its RGB) with its localisation status in the title: the engine's
    frame for a row of an engine version (``navbench-1+vizdoom``: the image the agent was given,
    issue 37), drawn ray-cast and titled so where the engine is not installed."""
    import numpy as np

    from navbench.benchmark import REFERENCE_SIM, split_version
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.levelio import load_level
    from navbench.sim.camera import RaycastCamera

    level = load_level(level_path)
    cam = RaycastCamera(level, camera_by_name("half"), CAMERA_HEIGHT)
    engines: dict = {}
    by_task = {(t.task_set_key, int(t.task_id)): (t.target_x, t.target_y) for t in tasks.itertuples()}
    try:
        for i, r in enumerate(rows.itertuples()):
            ax = fig.add_subplot(1, len(rows), i + 1)
            x, y = by_task[(r.task_set_key, int(r.task_id))]
            pose = np.array([x, y, float(r.goal_heading)])
            version = getattr(r, "benchmark_version", None)
            sim = split_version(version if isinstance(version, str) else "navbench-1")[1]
            engine, note = _engine(engines, sim, level) if sim != REFERENCE_SIM else (None, "")
            frame = (engine or cam).render(pose)
            ax.imshow(frame.rgb)
            ax.set_title(f"task {int(r.task_id)}: {r.goal_status}, {r.goal_err_m:.2f} m{note}", fontsize=8)
            ax.set_axis_off()
    finally:
        for engine in engines.values():
            if engine is not None:
                engine.close()


def _engine(engines: dict, sim: str, level):
    """``(renderer, title note)``: simulator ``sim``'s goal camera (kept in ``engines``), or
    ``(None, " (ray-cast: <sim> not installed)")``."""
    from navbench.errors import ConfigError

    if sim not in engines:
        from navbench.geometry import CAMERA_HEIGHT, camera_by_name
        from navbench.sim.backends import PoseRenderer, require_sim

        try:
            require_sim(sim)
            engines[sim] = PoseRenderer(sim, level, camera_by_name("half"), CAMERA_HEIGHT)
        except ConfigError:
            engines[sim] = None
    return engines[sim], "" if engines[sim] is not None else f" (ray-cast: {sim} not installed)"
