"""The report's localisation section (issue 14): RNR-Map Table 1b / 2 figures per study, the
error CDF, and a top view per level with the failed queries marked (as RNR-Map's Fig. 4: the
query red, the pose found blue)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: A query fails when it is found farther than this (m), RNR-Map's 50 cm recall.
FAIL_M = 0.5


def localization_table(rows: "Any", versions: "dict[int, str] | None" = None) -> "Any":
    """One row per study (``study_key``): level, changes, recall within 25 / 50 / 100 cm and
    within 50 cm and 10 deg, median errors, query-time median and p90, mean image difference.
    ``versions`` (run id -> benchmark version): adds the study's version, which names its
    simulator (``navbench-1+vizdoom``: the engine's frames; issue 37)."""
    import pandas as pd

    out = []
    for key, g in rows.groupby("study_key", sort=False):
        e, h = g["loc_err_m"].to_numpy(float), g["heading_err_deg"].to_numpy(float)
        ms = g["query_ms"].to_numpy(float)
        version = {} if versions is None else {"benchmark": versions.get(int(g["run_id"].iloc[0]), "navbench-1")}
        out.append({"level": g["level"].iloc[0], "changes": g["changes"].iloc[0] or "-", **version,
                    "queries": len(g), "recall_25cm": np.mean(e <= 0.25), "recall_50cm": np.mean(e <= 0.5),
                    "recall_100cm": np.mean(e <= 1.0), "recall_50cm_10deg": np.mean((e <= 0.5) & (h <= 10)),
                    "median_err_cm": 100 * np.median(e), "median_heading_deg": np.median(h),
                    "query_ms_median": np.nanmedian(ms), "query_ms_p90": np.nanpercentile(ms, 90),
                    "query_cpu_ms_median": np.nanmedian(g["query_cpu_ms"].to_numpy(float)),
                    "image_diff_mean": np.nanmean(g["image_diff"].to_numpy(float)), "study": key[:12]})
    return pd.DataFrame(out)


def section_localization(page: Any, db: Any, levels_dir: Path) -> None:
    """Append the section to ``page`` (a report ``_Page``); a note when no rows are stored."""
    from navbench.report.plots import draw_level_outline, plot_cdf

    page.h2("Localisation (RNR-Map Table 1b, 2; Fig. 4)", "localization")
    rows = db.localize_frame()
    if rows.empty:
        page.note("No localisation rows stored yet (navbench localize-eval LEVEL).")
        return
    from navbench.results.versions import versions_of

    runs = db.runs_frame()
    versions = dict(zip(runs["id"].astype(int), versions_of(runs))) if not runs.empty else {}
    page.table(localization_table(rows, versions), "localization",
               "Image-based localisation with no initial pose, per study (RNR-Map: recall 76.6 / 99.2 / "
               "99.5 % within 25 / 50 / 100 cm at 18 ms a query; OC1-OC4 50 cm recall 99.8 / 98.8 / 98.6 / 97.4 %)")
    from navbench.benchmark import REFERENCE_SIM, split_version

    def sim_of(run_id) -> str:
        """'' for the reference simulator, else its name (the label of an engine study)."""
        sim = split_version(versions.get(int(run_id), "navbench-1"))[1]
        return "" if sim == REFERENCE_SIM else sim

    rows = rows.assign(sim=[sim_of(r) for r in rows["run_id"]])
    groups = {" ".join(f"{g['level'].iloc[0]} {g['changes'].iloc[0] or ''} {g['sim'].iloc[0]}".split()):
              g["loc_err_m"].to_numpy(float) for _, g in rows.groupby("study_key", sort=False)}
    page.figure(lambda fig: plot_cdf(fig.add_subplot(), groups, "location error (m)", vline=FAIL_M,
                                     vline_label="50 cm"),
                "CDF of the location error per study", (7, 4.2))
    from navbench.levelio import load_level

    for (level, sim), g in rows[rows["changes"].isna()].groupby(["level", "sim"], sort=True):
        path = Path(levels_dir) / f"{level}.json"
        if not path.is_file():
            continue

        def draw(fig, g=g, lv=load_level(path)):
            ax = fig.add_subplot()
            draw_level_outline(ax, lv)
            ok = g["loc_err_m"] <= FAIL_M
            ax.plot(g.loc[ok, "true_x"], g.loc[ok, "true_y"], ".", color="#2a9d4b", ms=2, label="found")
            bad = g[~ok]
            for _, r in bad.iterrows():
                ax.plot([r.true_x, r.est_x], [r.true_y, r.est_y], color="grey", lw=0.6)
            ax.plot(bad["true_x"], bad["true_y"], "o", color="red", ms=4, label="failed query")
            ax.plot(bad["est_x"], bad["est_y"], "o", color="blue", ms=4, label="pose found")
            ax.legend(fontsize=7, loc="upper right")

        page.figure(draw, f"{level}{f' on {sim}' if sim else ''}: queries (green: found within 50 cm; "
                          "red: failed query, blue: the pose found for it)", (6, 6))
