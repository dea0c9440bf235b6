"""The results report: one self-contained ``index.html`` plus a CSV file of every table.

:func:`build_report` reads the results database only (scores are recomputed offline from the
stored episode rows), draws the paper's figures with :mod:`navbench.report.plots` and embeds
them as base64 PNG (no external resources: no scripts, fonts or style sheets are fetched).
Trajectories and maps come through two callables so the report does not depend on where they
are stored: ``load_trajectory(traj_key) -> {"true_poses", "est_poses", "target"}`` and
``load_map(map_key) -> WorldModel`` (:mod:`navbench.worldmodel.base`; the isometric view needs
a voxel map, another kind gets a note); :func:`navbench.pipeline.loaders.store_loaders` builds
both from the stage cache.

Sections: run metadata; SPL by estimator and noise (Fig. 5a, with intervals, next to the paper's
values); the full score table; location/orientation RMSE CDFs (Fig. 4a,b: from the tracking-study
rows when present, else from the navigation episodes); per-step runtime by component (Fig. 4c);
each level's top view with its tasks and a few true vs estimated trajectories (Fig. 3); the
learned maps' isometric views (Fig. 1, when :func:`navbench.worldmodel.plots.draw_isometric`
exists); map quality; benchmark history.
"""

from __future__ import annotations

import base64
import html
import io
import json
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from navbench.nav.timing import TIMING_COLUMNS
from navbench.results.score import (
    ESTIMATOR_ORDER,
    NOISE_ORDER,
    _order_key,
    conditions_in,
    estimator_variants,
    mixed_setups_warning,
    short_conditions,
    spl_matrix,
    summarise,
)
from navbench.report.leaderboard import section_compare, section_leaderboard

if TYPE_CHECKING:  # pragma: no cover
    from collections.abc import Collection

    import pandas

    from navbench.results.db import ResultsDB

TrajectoryLoader = Callable[[str], dict]
MapLoader = Callable[[str], Any]
DPI = 100


@dataclass
class _Page:
    """The report being assembled: HTML sections, CSV tables, notes."""

    out_dir: Path
    sections: list[str] = field(default_factory=list)
    csvs: list[str] = field(default_factory=list)
    figures: int = 0

    def h2(self, title: str, anchor: str) -> None:
        self.sections.append(f'<h2 id="{anchor}">{html.escape(title)}</h2>')

    def p(self, text: str, cls: str = "") -> None:
        c = f' class="{cls}"' if cls else ""
        self.sections.append(f"<p{c}>{html.escape(text)}</p>")

    def note(self, text: str) -> None:
        self.p(text, "note")

    def table(self, frame: "pandas.DataFrame", name: str, caption: str, index: bool = False,
              digits: int = 4, display: "pandas.DataFrame | None" = None, wrap: tuple[str, ...] = ()) -> None:
        """Write ``<name>.csv`` and show the table (or ``display``, a compact view of it) with
        labels and consistent decimals (:func:`navbench.report.display.shown`); the columns
        ``wrap`` (commands) break anywhere instead of widening the page."""
        from navbench.report.display import mark_column, shown as for_page

        self.csv(frame, name, index, digits)
        cols = list((frame if display is None else display).columns)
        shown = for_page(frame if display is None else display)
        for col in shown.columns:
            if shown[col].dtype == object:
                shown[col] = shown[col].map(_cell)
        body = shown.to_html(index=index, na_rep="–", border=0, classes="tbl", escape=True)
        for col in wrap:
            body = mark_column(body, cols.index(col), "wrap")
        self.sections.append(
            f'<figure class="table"><figcaption>{html.escape(caption)} '
            f'(<a href="{html.escape(name)}.csv">{html.escape(name)}.csv</a>)</figcaption>{body}</figure>')

    def csv(self, frame: "pandas.DataFrame", name: str, index: bool = False, digits: int = 4) -> None:
        """Write ``<name>.csv`` (full precision) without showing it."""
        frame.to_csv(self.out_dir / f"{name}.csv", index=index, float_format=f"%.{max(digits, 6)}g")
        self.csvs.append(f"{name}.csv")

    def figure(self, draw: Callable[[Any], None], caption: str, size: tuple[float, float]) -> bool:
        """Draw ``draw(fig)`` on a fresh figure and embed it as a base64 PNG; False on failure."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=size, dpi=DPI)
        FigureCanvasAgg(fig)
        try:
            draw(fig)
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
        except Exception as e:  # a figure that cannot be drawn becomes a note, not a failed report
            self.note(f"{caption}: figure unavailable ({type(e).__name__}: {e})")
            return False
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        self.figures += 1
        self.sections.append(
            f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")
        return True


def _cell(v: Any) -> Any:
    if v is None:
        return "–"
    if isinstance(v, (dict, list)):
        return json.dumps(v, sort_keys=True)
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:2em auto;max-width:1150px;
color:#222;padding:0 1em}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table.tbl{border-collapse:collapse;font-size:.82em;margin:.4em 0}
table.tbl td,table.tbl th{border:1px solid #ddd;padding:.2em .5em;text-align:right}
table.tbl th{background:#f3f3f3}figure{margin:1em 0}figure img{max-width:100%;height:auto}
figcaption{font-size:.85em;color:#555}.note{color:#8a6d3b;background:#fcf8e3;padding:.3em .6em}
nav a{margin-right:1em}.meta{font-size:.85em;color:#555}
table.tbl td.wrap{overflow-wrap:anywhere;text-align:left}
summary,figcaption,.meta,p{overflow-wrap:anywhere}
pre{font-size:.8em;background:#f7f7f7;padding:.5em;overflow-x:auto}details{margin:.3em 0;font-size:.9em}
"""


def _runtime_table(episodes: "pandas.DataFrame", tracking: "pandas.DataFrame") -> "pandas.DataFrame":
    """Median per-step milliseconds by component and estimator (episodes, else tracking rows)."""
    import pandas as pd

    if not episodes.empty:
        f = episodes.assign(estimator=estimator_variants(episodes))
        cols = [c for c in (*TIMING_COLUMNS, "step_ms") if c in f.columns]
        t = f.groupby("estimator")[cols].median()
        t.columns = [c[:-3] for c in cols]
    elif not tracking.empty:
        f = tracking.assign(estimator=estimator_variants(tracking))
        t = f.groupby("estimator")[["render_ms", "estimate_ms", "step_ms_median"]].median()
        t.columns = ["render", "estimate", "step_ms"]
    else:
        return pd.DataFrame()
    t = t.rename(columns={"step": "step_ms"})
    t = t.loc[sorted(t.index, key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))]
    t["step_hz"] = 1000.0 / t["step_ms"]
    t.index.name = "estimator"
    return t


def _cdf_groups(episodes: "pandas.DataFrame", tracking: "pandas.DataFrame"):
    """(source text, {label: loc values}, {label: rot values}, styles) for Fig. 4a,b."""
    from navbench.report.plots import estimator_colour, noise_linestyle

    if not tracking.empty:
        f = tracking.assign(variant=estimator_variants(tracking))
        src, keys = "tracking-study rows", ["variant"]
    elif not episodes.empty:
        f = episodes.assign(variant=estimator_variants(episodes))
        src, keys = "navigation episodes", ["variant", "noise"]
    else:
        return None
    loc, rot, styles = {}, {}, {}
    groups = sorted(f.groupby(keys), key=lambda kv: (
        _order_key(kv[0][0].split("{")[0], ESTIMATOR_ORDER),
        _order_key(kv[0][1], NOISE_ORDER) if len(keys) > 1 else (0, "")))
    for i, (k, g) in enumerate(groups):
        label = k[0] if len(keys) == 1 else f"{k[0]} ({k[1]})"
        loc[label] = g["loc_rmse_m"].to_numpy(dtype=float)
        rot[label] = g["rot_rmse_deg"].to_numpy(dtype=float)
        styles[label] = (estimator_colour(k[0], i), noise_linestyle(k[1]) if len(keys) > 1 else "-")
    return src, loc, rot, styles


def _versioned_tracking(tracking: "pandas.DataFrame", version: str | None):
    """``(rows, version, note)``: the tracking-study rows of ``version`` (the episodes'), or
    with no episodes of the newest version the rows hold; rows of two versions are never pooled."""
    from navbench.results.versions import choose_version, versions_of

    if version is None:
        return choose_version(tracking, None, "the tracking-study rows")
    same = versions_of(tracking) == version
    note = None if same.all() else f"{int((~same).sum())} tracking-study row(s) of another version left out."
    return tracking[same].reset_index(drop=True), version, note


def _level_file(levels_dir: Path, name: str, meta: dict | None) -> Path | None:
    candidates = [levels_dir / f"{name}.json"]
    if meta and isinstance(meta.get("path"), str):
        candidates.append(Path(meta["path"]))
    for c in candidates:
        if c.is_file():
            return c
    return None


RUNS_SHOWN = 10  # rows of the page's runs table (runs.csv has every run)


def _section_runs(page: _Page, runs: "pandas.DataFrame") -> None:
    page.h2("Runs", "runs")
    if runs.empty:
        page.note("No runs recorded yet.")
        return
    t = runs.drop(columns=["config"]).copy()
    t["git_commit"] = t["git_commit"].map(lambda s: s[:12] if isinstance(s, str) else s)
    t["config_hash"] = t["config_hash"].map(lambda s: s[:12] if isinstance(s, str) else s)
    secs = (t["finished"] - t["started"]).dt.total_seconds()
    t.insert(t.columns.get_loc("finished") + 1, "seconds", secs.round(1))
    for c in ("started", "finished"):
        t[c] = t[c].dt.strftime("%Y-%m-%d %H:%M:%S")
    caption = "Runs (times in UTC; config hash and commit abbreviated)"
    if (runs["status"] == "running").any():
        caption += ("; status running: the run had not finished when this page was written (a "
                    "`navbench all` run is marked done before it draws its report, so this is "
                    "another command, still running or killed)")
    if "benchmark_version" in t.columns:  # runs stored before versions: navbench-1
        from navbench.results.versions import versions_of

        t["benchmark_version"] = versions_of(t)
    shown = t.drop(columns=["proc_start", "pid", "navbench_version"], errors="ignore")
    if len(shown) > RUNS_SHOWN:  # a long-lived database: the page shows the newest, the CSV all
        caption += f"; the newest {RUNS_SHOWN} of {len(shown)} runs, every run in runs.csv"
        shown = shown.tail(RUNS_SHOWN)
    # proc_start and pid (the liveness of a running run) and the package version (the commit says
    # more) are in runs.csv, not in the page's width
    page.table(t, "runs", caption, display=shown, wrap=("command",))
    for _, r in runs.tail(5).iterrows():
        page.sections.append(
            f"<details><summary>Resolved config of run {int(r['id'])} ({html.escape(str(r['command']))}, "
            f"profile {html.escape(str(r['profile']))}, hash {html.escape(str(r['config_hash']))})</summary>"
            f"<pre>{html.escape(json.dumps(r['config'], indent=1, sort_keys=True))}</pre></details>")


def _section_spl(page: _Page, table: "pandas.DataFrame | None") -> None:
    import pandas as pd

    from navbench.report.plots import PAPER_SPL

    page.h2("Navigation: SPL by estimator and noise (Fig. 5a)", "spl")
    if table is None or table.empty:
        page.note("No navigation episodes stored yet (run `navbench run-navigation`).")
        return
    warning = mixed_setups_warning(table)
    if warning:
        page.note("Warning: " + warning.replace("--run", "`navbench report --run`") + ".")
    found = conditions_in(table) or [None]
    preset = table["preset"].iloc[0] if "preset" in table.columns and len(table) else "paper"  # issue 15
    page.p(conditions_sentence(found))
    section_leaderboard(page, table, preset)  # issue 35: SR, SPL and the paper's SPL in one table
    for i, conds in enumerate(found):  # Fig. 5a's layout, in the CSV files
        t = table if conds is None else table[table["conditions"] == conds]
        page.csv(spl_matrix(t, "all"), "spl_table" + (f"_{i + 1}" if i else ""), index=True)
    # Fig. 5a and its values are the paper's point-goal figure (issue 15: image goals are scored
    # in the goals section): an image-goal-only report sets nothing beside them
    has_point = "goal" not in table.columns or bool((table["goal"] == "point").any())
    drawn = found if has_point else []
    if has_point:
        paper = pd.DataFrame(
            [[PAPER_SPL.get((n, e), np.nan) for e in ("ours", "no-map", "dynamics")] for n in ("high", "mid", "low")],
            index=pd.Index(["high", "mid", "low"], name="noise"), columns=["ours", "no-map", "dynamics"])
        page.csv(paper, "spl_paper", index=True)  # shown beside navbench's in the leaderboard
    else:
        page.note("No point-goal episodes: the paper's Fig. 5a values and figure are left out; the "
                  "image-goal scores by difficulty are under 'Goals and difficulty'.")
    point = table[table["goal"] == "point"] if "goal" in table.columns and has_point else table
    for conds in drawn:
        t = point if conds is None else point[point["conditions"] == conds]
        under = "" if conds is None else f"; conditions: {conds}"
        page.figure(lambda fig, t=t, c=conds: _spl_panel(fig, t, c if len(drawn) > 1 else None),
                    "SPL per noise level and estimator, pooled over levels; error bars: 95% bootstrap "
                    f"interval; black ticks: the paper's values{under}", (8, 4.2))
    page.h2("Scores per level", "scores")
    page.p("Every stored episode counts once per (setup, task, seed); success rate and SPL are "
           "means, RMSEs and step times medians over episodes. 95% intervals: success rate exact "
           "binomial (Clopper-Pearson); SPL a BCa bootstrap stratified by level (each resample "
           "keeps every level's episode count); medians a percentile bootstrap.")
    page.table(table, "scores", "Scores per level, estimator, noise and goal (level 'all': pooled); "
               f"value [95% interval]; scoring preset '{preset}'; {conditions_sentence(found, short=True)}",
               digits=3, display=_compact_scores(table, several=len(found) > 1))
    idle = sorted(set(table.loc[~table["tracking_work"].astype(bool), "estimator"])) \
        if "tracking_work" in table.columns else []
    if idle:
        page.note(f"{', '.join(idle)}: no per-step tracking work, so no step time or rate is shown "
                  "(the step is the simulator and controller alone; scores.csv has its median).")


def _spl_panel(fig, table: "pandas.DataFrame", conditions: str | None) -> None:
    """Fig. 5a of one set of conditions (named in the title when the report has several)."""
    from navbench.report.plots import plot_spl

    ax = fig.add_subplot()
    plot_spl(ax, table, "all")
    if conditions is not None:
        ax.set_title(f"{ax.get_title()}\n{short_conditions(conditions)}", fontsize=10)


def conditions_sentence(found: list, short: bool = False) -> str:
    """What a report section says about the simulator conditions of its episodes (``found``:
    :func:`~navbench.results.score.conditions_in`; ``[None]`` when not known)."""
    found = [c for c in found if c is not None]
    if not found:
        return "Simulator conditions: not recorded with these episodes."
    if len(found) == 1:
        return f"{'s' if short else 'S'}imulator conditions of every episode: {found[0]}" + ("" if short else (
            " (navbench.sim.conditions: the paper's ViZDoom pose quantisation, its 5° "
            "movement-direction limit against the believed or the true heading, and its "
            "collision check)."))
    return (f"These episodes ran under {len(found)} sets of simulator conditions, never pooled "
            "into one row: " + " | ".join(found) + ".")


def _compact_scores(table: "pandas.DataFrame", several: bool = False) -> "pandas.DataFrame":
    """The score table with each metric and its interval in one ``"v [lo, hi]"`` cell (and the
    conditions that differ from the defaults when ``several`` sets are shown)."""
    import pandas as pd

    def fmt(r, m, d):
        v = r[m]
        if not np.isfinite(v):
            return "–"
        return f"{v:.{d}f} [{r[m + '_ci_low']:.{d}f}, {r[m + '_ci_high']:.{d}f}]"

    rows = []
    for _, r in table.iterrows():
        rows.append({"level": r["level"], "estimator": r["estimator"], "noise": r["noise"],
                     **({"conditions": short_conditions(r["conditions"])} if several else {}),
                     "goal": r.get("goal", "point"), "preset": r.get("preset", "paper"),
                     "episodes": r["episodes"], "success rate": fmt(r, "success_rate", 2),
                     "SPL": fmt(r, "spl", 2), "loc RMSE (m)": fmt(r, "loc_rmse_m", 3),
                     "rot RMSE (deg)": fmt(r, "rot_rmse_deg", 2),
                     "step (ms)": fmt(r, "step_ms", 1) if bool(r.get("tracking_work", True)) else "–",
                     "rate (Hz)": "–" if not np.isfinite(r["step_hz"]) else f"{r['step_hz']:.1f}"})
    return pd.DataFrame(rows)


def _section_tracking(page: _Page, episodes, tracking, bench=None, runs=None) -> None:
    import pandas as pd

    from navbench.report.plots import plot_loc_cdf, plot_rot_cdf, plot_step_runtime

    page.h2("Tracking accuracy (Fig. 4a, b)", "tracking")
    groups = _cdf_groups(episodes, tracking)
    if groups is None:
        page.note("No tracking rows or episodes stored yet.")
    else:
        src, loc, rot, styles = groups

        def draw(fig):
            a, b = fig.subplots(1, 2)
            plot_loc_cdf(a, loc, styles)
            plot_rot_cdf(b, rot, styles)

        page.figure(draw, f"CDF of the per-trajectory location and orientation RMSE ({src}); "
                          "dotted line: 0.5 x agent size", (11, 4.2))
        rows = []
        for label in loc:
            lv, rv = loc[label], rot[label]
            lv_f = lv[np.isfinite(lv)]
            rows.append({"estimator": label, "trajectories": int(lv.size),
                         "loc_rmse_median_m": float(np.median(lv_f)) if lv_f.size else np.nan,
                         "frac_loc_rmse_below_0.1m": float(np.mean(lv_f < 0.1)) if lv_f.size else np.nan,
                         "rot_rmse_median_deg": float(np.nanmedian(rv)) if np.isfinite(rv).any() else np.nan})
        page.table(pd.DataFrame(rows), "tracking_summary",
                   f"Tracking accuracy summary ({src}); the paper: location RMSE < 0.1 m in > 99% of trajectories")
    page.h2("Per-step runtime (Fig. 4c)", "runtime")
    rt = _runtime_table(episodes, tracking)
    if rt.empty:
        page.note("No timings stored yet.")
        return
    from navbench.report.claim import section_speed_vs_paper, split_no_work

    work, idle = split_no_work(rt)
    if not work.empty:
        page.figure(lambda fig: plot_step_runtime(fig.add_subplot(), work),
                    "Median time per step by component (sim, render, estimate, plan, control); "
                    "label: median total step time and rate", (9, 0.7 + 0.55 * len(work)))
    if idle:
        rt.loc[idle, "step_hz"] = np.nan  # not a tracking rate: shown as "–"
        page.note(f"{', '.join(idle)}: no per-step tracking work (no map render, no "
                  "optimisation); their step is the simulator and controller alone, left out of "
                  "the figure, and no rate is given.")
    page.table(rt, "runtime", "Median per-step milliseconds by component", index=True, digits=4)
    section_speed_vs_paper(page, episodes, bench, runs)


def _section_levels(page: _Page, db: "ResultsDB", episodes, levels_dir: Path,
                    load_trajectory: TrajectoryLoader | None, per_level: int,
                    load_map: MapLoader | None = None) -> None:
    from navbench.errors import NavbenchError
    from navbench.levelio import load_level

    page.h2("Levels, tasks and trajectories (Fig. 3)", "levels")
    lv = db.levels_frame()
    names = list(dict.fromkeys(list(lv["name"]) + (list(episodes["level"]) if not episodes.empty else [])))
    if not names:
        page.note("No levels recorded yet.")
        return
    if load_trajectory is None:
        page.note("No trajectory loader given: levels are drawn without trajectories.")
    for name in sorted(names):
        meta = lv[lv["name"] == name]["meta"].iloc[-1] if (lv["name"] == name).any() else None
        path = _level_file(levels_dir, name, meta)
        if path is None:
            page.note(f"Level {name}: no level file in {levels_dir}; top view skipped.")
            continue
        try:
            level = load_level(path)
        except NavbenchError as e:
            page.note(f"Level {name}: {e}")
            continue
        eps = episodes[episodes["level"] == name] if not episodes.empty else episodes
        tasks = None
        if not eps.empty and eps["task_set_key"].notna().any():
            tasks = db.tasks_frame(task_set_key=eps["task_set_key"].dropna().iloc[-1])
        if tasks is None or tasks.empty:
            tasks = db.tasks_frame(level=name)
            if not tasks.empty:
                tasks = tasks[tasks["task_set_key"] == tasks["task_set_key"].iloc[-1]]
        from navbench.report.claim import level_runs_figure

        level_runs_figure(page, name, level, tasks, eps, load_trajectory, load_map, per_level)


def _section_maps(page: _Page, maps: "pandas.DataFrame", load_map: MapLoader | None) -> None:
    page.h2("Learned maps (Fig. 1) and map quality", "maps")
    if maps.empty:
        page.note("No fitted maps recorded yet.")
        return
    try:
        from navbench.worldmodel.plots import draw_isometric
    except ImportError:
        draw_isometric = None
    if draw_isometric is None:
        page.note("Isometric map views skipped: navbench.worldmodel.plots.draw_isometric is not available.")
    elif load_map is None:
        page.note("Isometric map views skipped: no map loader given.")
    else:
        latest = maps.drop_duplicates("level", keep="last")
        for _, m in latest.iterrows():
            try:
                vmap = load_map(m["map_key"])
            except Exception as e:  # a missing or collected artifact is a note
                page.note(f"Map of {m['level']} ({str(m['map_key'])[:12]}) unavailable: {e}")
                continue
            page.figure(lambda fig, vmap=vmap: _draw_iso(fig, draw_isometric, vmap),
                        f"{m['level']}: isometric view of the learned map {str(m['map_key'])[:12]}", (7, 6))
    cols = ["level", "map_key", "depth_mae_m", "rgb_l1", "slice_precision", "slice_recall",
            "fit_seconds", "steps", "recorded"]
    t = maps[cols].copy()
    t["map_key"] = t["map_key"].map(lambda s: str(s)[:12])
    t["recorded"] = t["recorded"].dt.strftime("%Y-%m-%d %H:%M:%S")
    page.table(t, "maps", "Map quality: held-out depth MAE (m), RGB L1, horizontal-slice precision/recall")


def _draw_iso(fig, draw_isometric, vmap) -> None:
    """``draw_isometric`` on a 2D axis, or on a 3D one if it needs that."""
    ax = fig.add_subplot()
    try:
        draw_isometric(ax, vmap)
    except (AttributeError, TypeError):
        fig.clear()
        draw_isometric(fig.add_subplot(projection="3d"), vmap)


def _section_bench(page: _Page, bench: "pandas.DataFrame") -> None:
    page.h2("Benchmark history", "bench")
    if bench.empty:
        page.note("No benchmark rows yet (run `navbench bench`).")
        return
    t = bench[["recorded", "run_id", "metric", "value", "unit", "device", "host", "cpu",
               "navbench_version"]].copy()
    t["recorded"] = t["recorded"].dt.strftime("%Y-%m-%d %H:%M:%S")
    page.table(_bench_history(t), "bench_history",
               f"The last {BENCH_HISTORY_RUNS} benchmark runs side by side: one column per run "
               "(its id, start time and host), one row per measurement and device", index=True)
    page.table(t, "bench", "Every benchmark row, oldest first")


#: Benchmark runs shown side by side in the report's history table.
BENCH_HISTORY_RUNS = 8


def _bench_history(rows: "pandas.DataFrame") -> "pandas.DataFrame":
    """``rows`` (bench rows with a formatted ``recorded``) pivoted: index (metric, unit, device),
    one column per run of the last :data:`BENCH_HISTORY_RUNS`, oldest first."""
    runs = rows.groupby("run_id", sort=True).agg(recorded=("recorded", "min"), host=("host", "first"))
    runs = runs.tail(BENCH_HISTORY_RUNS)
    label = {rid: f"run {rid}, {r.recorded[:16]}, {r.host}" for rid, r in runs.iterrows()}
    kept = rows[rows["run_id"].isin(runs.index)]
    wide = kept.pivot_table(index=["metric", "unit", "device"], columns="run_id", values="value",
                            aggfunc="first", sort=False)
    return wide[list(runs.index)].rename(columns=label)


def build_report(db: "ResultsDB", out_dir: str | Path, load_trajectory: TrajectoryLoader | None = None,
                 load_map: MapLoader | None = None, levels_dir: str | Path = "levels", *,
                 n_boot: int = 2000, seed: int = 0, trajectories_per_level: int = 3,
                 run: int | str | None = None, cell_keys: "Collection[str] | None" = None,
                 preset: str = "paper", pairs=(), benchmark_version: str | None = None,
                 b_db: "ResultsDB | None" = None) -> Path:
    """Write ``out_dir/index.html`` and one CSV per table; returns the path of ``index.html``.

    Works on any database state (sections without data show a note). ``levels_dir`` holds the
    ``NAME.json`` level files for the top views. The navigation sections show every stored
    episode, or those of ``run`` (as :func:`~navbench.results.score.select_episodes`) and/or of
    the cells ``cell_keys`` (``navbench all`` passes its grid's cells). Success and SPL follow
    the scoring ``preset`` (:mod:`navbench.nav.presets`), named beside every score table, and
    one benchmark version: ``benchmark_version``, else the newest of the selection (named at the
    top of the report, with the versions left out). ``pairs``: ``(A, B)`` estimator names whose
    B - A the report shows (``report --pair``). The version's episodes on another simulator, of this
    database's selection or of ``b_db`` (``report --b-db``), are set beside it in a section of
    their own (:mod:`navbench.report.simulators`).
    """
    from navbench import __version__
    from navbench.report.display import plural

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    page = _Page(out)
    runs = db.runs_frame()
    from navbench.results.presets import apply_preset

    from navbench.results.score import select_versioned

    selected, version, version_note = select_versioned(db, run=run, cell_keys=cell_keys,
                                                       benchmark_version=benchmark_version)
    episodes = apply_preset(selected, preset)
    table = summarise(episodes, n_boot=n_boot, seed=seed) if not episodes.empty else None
    tracking, version, track_note = _versioned_tracking(db.tracking_frame(), version)

    from navbench.report.claim import section_claim, section_failures

    if version is not None:
        page.p(f"Benchmark version {version}: every navigation score and tracking figure below is "
               "of this version only." + "".join(f" {n}" for n in (version_note, track_note) if n), "meta")
    _section_runs(page, runs)
    _section_spl(page, table)
    section_claim(page, episodes, n_boot, seed)
    section_compare(page, episodes, pairs, n_boot, seed)  # issue 35: report --pair
    from navbench.report.simulators import section_simulators, simulator_sides  # issue 37 §4

    sims = section_simulators(page, *simulator_sides(db, version, episodes, run, cell_keys, b_db), preset, n_boot, seed)
    section_failures(page, episodes)
    from navbench.report.goals import section_goals  # issue 15

    section_goals(page, episodes, Path(levels_dir), db.tasks_frame(), load_trajectory, load_map)
    _section_tracking(page, episodes, tracking, db.bench_frame(), runs)
    _section_levels(page, db, episodes, Path(levels_dir), load_trajectory, trajectories_per_level,
                    load_map)
    _section_maps(page, db.maps_frame(), load_map)
    _section_bench(page, db.bench_frame())
    from navbench.report.localize import section_localization  # issue 14

    section_localization(page, db, Path(levels_dir))

    now = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    nav = " ".join(f'<a href="#{a}">{t}</a>' for a, t in (
        ("runs", "Runs"), ("spl", "SPL"), ("claim", "Claim"), *((("compare", "Comparisons"),) if pairs else ()),
        *((("simulators", "Simulators"),) if sims else ()),
        ("failures", "Failures"), ("scores", "Scores"), ("goals", "Goals"), ("tracking", "Tracking"),
        ("runtime", "Runtime"), ("levels", "Levels"), ("maps", "Maps"), ("bench", "Bench"),
        ("localization", "Localisation")))
    doc = (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
        "<title>navbench report</title>"
        f"<style>{_CSS}</style></head><body>\n"
        "<h1>navbench report: Tracking and Planning with Spatial World Models</h1>\n"
        f"<p class=\"meta\">Generated {now} by navbench {html.escape(__version__)} from "
        f"{html.escape(db.display_url)}: {plural(len(runs), 'run')}, {plural(len(episodes), 'episode')}"
        + (f", {plural(len(tracking), 'tracking-study row')}" if len(tracking) else "") + ". CSV files: "
        + ", ".join(f'<a href="{html.escape(c)}">{html.escape(c)}</a>' for c in page.csvs)
        + f".</p>\n<nav>{nav}</nav>\n" + "\n".join(page.sections) + "\n</body></html>\n")
    from navbench.outpath import write_text_atomic

    return write_text_atomic(out / "index.html", doc)
