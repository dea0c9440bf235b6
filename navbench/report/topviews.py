"""The report's top views of online image-goal episodes (issue 15 section 5).

For ``run-navigation --goal image --map online|online-fused`` rows, per level and set of
conditions, one figure with a panel per episode (the first :data:`TOPVIEWS_PER_GROUP`): the
level seen from above (:func:`navbench.report.plots.plot_level_runs`), the cells the agent had
seen when the episode ended shaded (the record's ``known (nx, ny)`` planning cells, on the grid
of the map the loop read: :func:`known_grid`), the true path (the estimated one dashed when it
differs), start dot, true goal star, stop point, the outcome in the title and the goal image the
agent was given beneath (rendered again from the level file: the ``half`` camera, the target and
the stored heading, as :func:`navbench.report.goals._draw_goals`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: Episodes drawn per level and set of conditions.
TOPVIEWS_PER_GROUP = 6
#: Panels per figure row.
TOPVIEW_COLUMNS = 3
#: The explored (known) cells' colour (RGB) and alpha.
KNOWN_COLOUR = (0.12, 0.47, 0.71)
KNOWN_ALPHA = 0.28


def online_extras(npz_path: Path) -> dict:
    """What an online episode artifact (:class:`~navbench.nav.imagenav.OnlineEpisodeRecord`
    saved by :func:`~navbench.pipeline.artifacts.save_record`) keeps beyond an
    :class:`~navbench.nav.episode.EpisodeRecord`: ``known (nx, ny)`` bool and ``seen_share``;
    ``{}`` for any other record (read without importing the navigation loop)."""
    import json

    with np.load(npz_path, allow_pickle=False) as z:
        if "known" not in z.files:
            return {}
        meta = json.loads(bytes(z["__meta__"]).decode())
        share = meta.get("seen_share")
        return {"known": np.asarray(z["known"], bool),
                "seen_share": float("nan") if share is None else float(share)}


def known_grid(vmap, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray] | None:
    """The cell centres ``(xs, ys)`` of a ``known (nx, ny)`` array of the loop that read ``vmap``
    (its planning slice's grid: :meth:`~navbench.worldmodel.grid.VoxelMap.occupancy_slice`);
    ``None`` when that grid has another shape."""
    spec = getattr(vmap, "spec", None)
    if spec is not None and hasattr(spec, "centres"):
        xs, ys = np.asarray(spec.centres(0), float), np.asarray(spec.centres(1), float)
    else:
        _, xs, ys = vmap.occupancy_slice("band")
    return (xs, ys) if (len(xs), len(ys)) == tuple(shape) else None


def _outcome(row) -> str:
    """``success`` or the failure and its end reason (``stopped`` when the agent stopped wrong)."""
    if bool(row.get("success")):
        return "success"
    reason = str(row.get("end_reason", "?"))
    return "failed: " + ("stopped too far" if reason == "reached" else reason)


def first_episodes(rows, n: int = TOPVIEWS_PER_GROUP):
    """The episodes of ``rows`` drawn: ordered by noise, estimator, seed and task, then taken one
    difficulty after the other (easy, medium, hard, other: :data:`DIFFICULTY_ORDER`) so that a
    capped figure shows every difficulty; the first ``n``."""
    from navbench.results.presets import DIFFICULTY_ORDER

    order = [c for c in ("noise", "estimator", "seed", "task_id") if c in rows.columns]
    rows = rows.sort_values(order, kind="stable")
    if "difficulty" not in rows.columns:
        return rows.head(n)
    rank = rows.groupby(rows["difficulty"].astype(str), sort=False).cumcount()
    band = rows["difficulty"].astype(str).map(
        lambda d: DIFFICULTY_ORDER.index(d) if d in DIFFICULTY_ORDER else len(DIFFICULTY_ORDER))
    return rows.assign(_rank=rank, _band=band).sort_values(["_rank", "_band"], kind="stable") \
        .head(n).drop(columns=["_rank", "_band"])


def section_online_topviews(page: Any, rows, levels_dir: Path | None, load_trajectory, load_map) -> None:
    """Top views of the online image-goal episodes ``rows`` (module docstring): one figure per
    level and conditions; notes instead where the level file or the trajectories are missing."""
    from navbench.errors import NavbenchError
    from navbench.levelio import load_level
    from navbench.results.score import short_conditions

    if levels_dir is None or load_trajectory is None:
        page.note("Online image-goal episodes: no level directory or trajectory loader given; "
                  "top views skipped.")
        return
    rows = rows.assign(conditions=[short_conditions(c) for c in
                                   rows.get("conditions", ["unrecorded"] * len(rows))])
    for (name, conds), g in rows.groupby(["level", "conditions"], sort=True):
        path = Path(levels_dir) / f"{name}.json"
        try:
            level = load_level(path)
        except (NavbenchError, OSError) as e:
            page.note(f"{name}: top views of the online episodes skipped ({e})")
            continue
        first = first_episodes(g)
        episodes, failed = [], 0
        for _, r in first.iterrows():
            try:
                episodes.append((r, dict(load_trajectory(r["traj_key"]))))
            except (NavbenchError, OSError, KeyError, ValueError):
                failed += 1
        if failed:
            page.note(f"{name} ({conds}): {failed} of its {len(first)} online trajectory artifact(s) "
                      "unavailable (not in this cache: run elsewhere, or removed)")
        if not episodes:
            continue
        grid, grid_note = None, ""
        shapes = {np.shape(tr["known"]) for _, tr in episodes if np.size(tr.get("known", ())) > 0}
        if not shapes:
            grid_note = "; the explored area is not stored with these trajectories"
        elif load_map is None or not g["map_key"].notna().any():
            grid_note = "; explored area not drawn (no map to place its cells)"
        else:
            try:
                grid = known_grid(load_map(g["map_key"].dropna().iloc[0]), shapes.pop())
            except Exception as err:  # a map that cannot be loaded is a note, as in Fig. 3
                grid_note = f"; explored area not drawn ({type(err).__name__})"
            else:
                grid_note = "" if grid is not None else "; explored area not drawn (grid mismatch)"
        several = len({(r.get("estimator"), r.get("noise")) for r, _ in episodes}) > 1
        ncols = min(TOPVIEW_COLUMNS, len(episodes))
        nrows = -(-len(episodes) // ncols)
        aspect = level.depth / max(level.width, 1e-9)
        page.figure(lambda fig, lv=level, eps=episodes, grid=grid, sev=several:
                    draw_online_topviews(fig, lv, eps, grid, sev),
                    f"{name}: top views of {len(episodes)} of {len(g)} online image-goal episodes "
                    f"(the first of each difficulty in turn; conditions: {conds}); shaded blue: the "
                    "cells the agent had seen when it ended; line: its true path (green: success, "
                    "orange: failed; dashed: its estimate); dot: start; star: the true goal; square: "
                    "where it stopped (black cross when it failed); below each: the goal image it "
                    "was given" + grid_note,
                    (3.4 * ncols, nrows * (3.4 * aspect + 1.9)))


def draw_online_topviews(fig, level, episodes, grid, several: bool = False) -> None:
    """One panel per ``(row, trajectory)`` of ``episodes`` (module docstring); ``grid`` the
    ``(xs, ys)`` of the trajectories' ``known`` cells (``None``: no shading)."""
    from matplotlib.gridspec import GridSpec

    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.report.plots import plot_level_runs, plot_planning_slice
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(level, camera_by_name("half"), CAMERA_HEIGHT)
    ncols = min(TOPVIEW_COLUMNS, len(episodes))
    nrows = -(-len(episodes) // ncols)
    aspect = level.depth / max(level.width, 1e-9)
    gs = GridSpec(2 * nrows, ncols, figure=fig, height_ratios=[3.4 * aspect, 1.6] * nrows,
                  hspace=0.35, wspace=0.15)
    for i, (row, tr) in enumerate(episodes):
        ax = fig.add_subplot(gs[2 * (i // ncols), i % ncols])
        success = bool(row.get("success"))
        colour = "#1b9e77" if success else "#d95f02"
        plot_level_runs(ax, level, trajectories=[{**tr, "failed": not success}], colours=[colour],
                        legend=False, free_space=False)
        known = np.asarray(tr.get("known", np.zeros((0, 0))), bool)
        if grid is not None and known.shape == (len(grid[0]), len(grid[1])):
            plot_planning_slice(ax, known, *grid, colour=KNOWN_COLOUR, alpha=KNOWN_ALPHA,
                                zorder=0.5)
            ax.set_xlim(0, level.width)
            ax.set_ylim(0, level.depth)
        true = np.asarray(tr["true_poses"], float)
        ax.plot(true[-1, 0], true[-1, 1], marker="s", color=colour, markersize=5,
                markeredgecolor="black", markeredgewidth=0.5, zorder=8.5)
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.tick_params(labelsize=6)
        diff = row.get("difficulty")
        head = f"task {int(row['task_id'])}" + (f" ({diff})" if isinstance(diff, str) else "")
        if several:
            head += f", {row.get('estimator')}, {row.get('noise')}"
        share = tr.get("seen_share", float("nan"))
        seen = f", seen {100 * share:.0f} %" if share == share else ""
        ax.set_title(f"{head}\n{_outcome(row)}, {len(true) - 1} steps{seen}", fontsize=7)
        gax = fig.add_subplot(gs[2 * (i // ncols) + 1, i % ncols])
        heading = row.get("goal_heading")
        target = np.asarray(tr.get("target", (np.nan, np.nan)), float)
        if heading is not None and heading == heading and np.isfinite(target[:2]).all():
            gax.imshow(cam.render(np.array([target[0], target[1], float(heading)])).rgb)
            gax.set_title(f"goal image ({str(row.get('goal_status', '')).removeprefix('online-')})",
                          fontsize=6)
        gax.set_axis_off()
