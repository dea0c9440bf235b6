"""The report's goals section (issue 15): scores under the chosen preset by NRNS difficulty and
goal kind, and how the image goals were localised."""

from __future__ import annotations

from typing import Any

from navbench.nav.presets import PRESETS


def section_goals(page: Any, episodes) -> None:
    """Scores by difficulty and goal (:func:`navbench.pipeline.score.difficulty_table`)
    and, where image goals were run, the goal-localisation outcomes per level."""
    from navbench.pipeline.score import difficulty_table

    page.h2("Goals and difficulty (scoring preset)", "goals")
    if episodes is None or episodes.empty:
        page.note("No navigation episodes stored yet.")
        return
    name = episodes.attrs.get("preset", "paper")
    page.p(f"Scoring preset '{name}': {PRESETS[name].description}. SoftSPL: habitat-lab's "
           "max(0, 1 - d_T / d_0) * d_0 / max(p, d_0) with the final geodesic distance d_T; final "
           "distance: the preset's d_T (mean, m). Difficulty: NRNS bands of the exact geodesic "
           "start-goal distance (easy 1.5-3 m, medium 3-5 m, hard 5-10 m; 'other' outside them).")
    page.table(difficulty_table(episodes), "by_difficulty",
               f"Success rate [95% exact interval], SPL, SoftSPL and final distance by goal and "
               f"difficulty, scored under the '{name}' preset", digits=3)
    if "goal_status" not in episodes.columns or episodes["goal"].eq("image").sum() == 0:
        return
    img = episodes[episodes["goal"] == "image"]
    counts = (img.groupby(["level", "goal_status"]).size().unstack(fill_value=0)
              .reindex(columns=["ok", "ambiguous", "failed"], fill_value=0))
    counts["median error (m)"] = img.groupby("level")["goal_err_m"].median()
    page.table(counts, "goal_localization", "Image goals: localisation of the goal image in the "
               "map per episode (ok / ambiguous / failed) and the median distance of the found goal "
               "to the true one", index=True, digits=3)
