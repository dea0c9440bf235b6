"""Report sections of issue 16: the paper's claim as paired differences, why episodes end, and
the per-step speed beside the paper's Fig. 4c.

Each ``section_*`` function appends to a report page (:class:`navbench.report.build._Page`,
passed in: this module does not import the report, which imports it) and reads plain frames:
the episodes of :func:`navbench.results.score.select_episodes`, bench rows.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from navbench.results.score import (
    CLAIM_OTHERS,
    CLAIM_REFERENCE,
    ESTIMATOR_ORDER,
    NO_WORK_MS,
    NOISE_ORDER,
    _order_key,
    conditions_in,
    estimator_variants,
    paired_differences,
    short_conditions,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas

#: Columns of the per-episode CSV (``episodes.csv``), in this order (those present).
EPISODE_CSV_COLUMNS = (
    "level", "estimator", "estimator_options", "noise", "conditions", "task_id", "seed", "success", "spl_term",
    "path_length", "optimal_length", "steps", "end_reason", "collided", "loc_rmse_m",
    "rot_rmse_deg", "sim_ms", "render_ms", "estimate_ms", "plan_ms", "control_ms", "step_ms",
    "run_id", "map_key", "task_set_key", "cell_key", "condition_key", "traj_key",
)


def _fmt(v: float, lo: float, hi: float, d: int = 3) -> str:
    if not np.isfinite(v):
        return "–"
    return f"{v:+.{d}f} [{lo:+.{d}f}, {hi:+.{d}f}]"


def paper_difference(noise: str, other: str) -> float:
    """The paper's ``ours - other`` SPL margin at ``noise`` (Fig. 5a), nan when it has none."""
    from navbench.report.plots import PAPER_SPL

    a = PAPER_SPL.get((noise, CLAIM_REFERENCE))
    b = PAPER_SPL.get((noise, other.split("{")[0]))
    return float(a - b) if a is not None and b is not None else float("nan")


def claim_tables(paired: "pandas.DataFrame") -> dict[str, "pandas.DataFrame"]:
    """One display table per noise level (keys in :data:`NOISE_ORDER`): rows (level, comparison),
    pooled ``all`` first; SPL and success differences with their intervals, the pair counts and
    the paper's margin."""
    import pandas as pd

    out = {}
    for noise in sorted(paired["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER)):
        p = paired[paired["noise"] == noise]
        p = p.iloc[sorted(range(len(p)), key=lambda i: (p["level"].iloc[i] != "all", p["level"].iloc[i]))]
        rows = []
        for _, r in p.iterrows():
            pm = paper_difference(noise, r["other"])
            rows.append({"level": r["level"], "comparison": r["comparison"], "pairs": int(r["pairs"]),
                         "unpaired (ref / other)": f"{int(r['unpaired_reference'])} / {int(r['unpaired_other'])}",
                         "SPL ref / other": (f"{r['reference_spl']:.3f} / {r['other_spl']:.3f}"
                                             if r["pairs"] else "–"),
                         "SPL difference [95%]": _fmt(r["spl_diff"], r["spl_diff_ci_low"], r["spl_diff_ci_high"]),
                         "success difference [95%]": _fmt(r["success_diff"], r["success_diff_ci_low"],
                                                          r["success_diff_ci_high"]),
                         "paper SPL difference": f"{pm:+.2f}" if np.isfinite(pm) else "–"})
        out[noise] = pd.DataFrame(rows)
    return out


def section_claim(page: Any, episodes: "pandas.DataFrame", n_boot: int, seed: int) -> None:
    """The paper's claim (Fig. 5a's margins): ``ours - no-map`` and ``ours - dynamics`` on the
    same tasks and seeds, one table per noise level, a figure, and ``paired_differences.csv``."""
    from navbench.report.plots import plot_paired_differences

    page.h2("The paper's claim: ours against each ablation on the same episodes", "claim")
    if episodes is None or episodes.empty:
        page.note("No navigation episodes stored yet.")
        return
    paired = paired_differences(episodes, n_boot=n_boot, seed=seed)
    if paired.empty:
        page.note(f"No pairs to compare: the claim needs {CLAIM_REFERENCE!r} and at least one of "
                  f"{', '.join(CLAIM_OTHERS)} in the same run.")
        return
    page.p("Each difference is the mean over pairs of (ours − other) for the two estimators' "
           "episodes on the same level, map, noise, episode settings, task and seed (the same "
           "simulator noise stream), so the spread of tasks cancels. Intervals: 95 % BCa "
           "bootstrap resampling pairs within each level (stratified by level). Episodes without "
           "a partner are left out and counted. The paper's margins are its Fig. 5a averages "
           "(not paired).")
    found = conditions_in(paired) or [None]
    preset = episodes.attrs.get("preset", "paper")
    for i, conds in enumerate(found):
        p = paired if conds is None else paired[paired["conditions"] == conds]
        under = "" if conds is None else f"; conditions: {conds}"
        for noise, t in claim_tables(p).items():
            page.table(t, f"claim_{noise}" + (f"_{i + 1}" if i else ""),
                       f"Noise {noise}: ours − ablation on the same (task, seed){under}; "
                       f"scoring preset '{preset}'")
    paired.to_csv(page.out_dir / "paired_differences.csv", index=False, float_format="%.6g")
    page.csvs.append("paired_differences.csv")
    page.sections.append('<p class="meta">Every level, noise and comparison with full precision: '
                         '<a href="paired_differences.csv">paired_differences.csv</a>.</p>')
    for conds in found:
        pooled = paired[(paired["level"] == "all")
                        & ((paired["conditions"] == conds) if conds is not None else True)]
        under = "" if conds is None else f"; conditions: {conds}"
        page.figure(lambda fig, pooled=pooled: plot_paired_differences(fig.add_subplot(), pooled,
                                                                       paper_difference),
                    "SPL difference ours − ablation pooled over levels, with its 95 % interval "
                    f"(paired, stratified bootstrap); black ticks: the paper's margin{under}", (8, 3.6))


def end_reason_counts(episodes: "pandas.DataFrame") -> "pandas.DataFrame":
    """Episodes by end reason per (estimator, noise, conditions): columns ``episodes``, one per
    end reason (``reached``, ``step-limit``, ``stuck``, ``no-plan``, then any other),
    ``collided`` (the episodes whose agent hit a wall or furniture) and ``failed`` (not a
    success). ``conditions`` (the short label, :func:`~navbench.results.score.short_conditions`)
    appears only when the episodes ran under more than one set of conditions."""
    import pandas as pd

    if episodes.empty:
        return pd.DataFrame()
    conds = (episodes["conditions"].astype(str) if "conditions" in episodes.columns
             else episodes["level"].map(lambda _: ""))
    f = episodes.assign(variant=estimator_variants(episodes), conditions=conds,
                        end_reason=episodes["end_reason"].fillna("unknown"))
    several = f["conditions"].nunique() > 1
    known = ["reached", "step-limit", "stuck", "no-plan"]
    reasons = known + sorted(set(f["end_reason"]) - set(known))
    rows = []
    for (est, noise, c), g in f.groupby(["variant", "noise", "conditions"], sort=False):
        row = {"estimator": est, "noise": noise, **({"conditions": short_conditions(c)} if several else {}),
               "episodes": len(g)}
        for r in reasons:
            row[r] = int((g["end_reason"] == r).sum())
        row["collided"] = int(g["collided"].fillna(False).astype(bool).sum())
        row["failed"] = int((~g["success"].astype(bool)).sum())
        rows.append(row)
    t = pd.DataFrame(rows)
    cs = t["conditions"] if "conditions" in t.columns else [""] * len(t)
    key = [(c, _order_key(n, NOISE_ORDER), _order_key(e.split("{")[0], ESTIMATOR_ORDER), e)
           for e, n, c in zip(t["estimator"], t["noise"], cs)]
    return t.iloc[sorted(range(len(t)), key=lambda i: key[i])].reset_index(drop=True)


def section_failures(page: Any, episodes: "pandas.DataFrame") -> None:
    """Why episodes end: counts by end reason per estimator and noise, and the per-episode CSV."""
    page.h2("Why episodes fail", "failures")
    if episodes is None or episodes.empty:
        page.note("No navigation episodes stored yet.")
        return
    from navbench.nav.presets import PRESETS

    preset = episodes.attrs.get("preset", "paper")
    rule = PRESETS[preset].description if preset in PRESETS else "the paper's rule"
    page.p("End reasons: reached (the agent believes it has arrived, or stopped by its own decision "
           f"in an unknown house; success is judged on the true position, under the scoring preset "
           f"'{preset}': {rule}), stuck (a collision: movement is prohibited from then on), "
           "step-limit (500 steps), no-plan (A* found no path on the map), explored (unknown house: "
           "everything reachable seen and the goal never matched). collided counts the episodes "
           "that hit a wall or furniture.")
    found = conditions_in(episodes)
    under = f"; conditions: {found[0]}" if len(found) == 1 else ""
    page.table(end_reason_counts(episodes), "end_reasons",
               f"Episodes by end reason, per estimator and noise (all levels){under}")
    cols = [c for c in EPISODE_CSV_COLUMNS if c in episodes.columns]
    e = episodes[cols].copy()
    if "estimator_options" in e.columns:
        import json

        e["estimator_options"] = e["estimator_options"].map(
            lambda o: json.dumps(o if isinstance(o, dict) else {}, sort_keys=True))
    e.to_csv(page.out_dir / "episodes.csv", index=False, float_format="%.6g")
    page.csvs.append("episodes.csv")
    page.sections.append(f'<p class="meta">Every episode of this report ({len(e)} row{"" if len(e) == 1 else "s"}: level, '
                         'estimator, noise, task, seed, outcome, end reason, RMSEs, per-step '
                         'timings, keys): <a href="episodes.csv">episodes.csv</a>.</p>')


def split_no_work(runtime: "pandas.DataFrame") -> tuple["pandas.DataFrame", list[str]]:
    """``(rows that do per-step work, labels that do not)`` of a runtime table (index estimator,
    columns component ms and ``step_ms``): an estimator whose median render + estimate time is
    below :data:`NO_WORK_MS` (``dynamics``, ``gt``) tracks nothing; its step time is the
    simulator's and controller's alone, and its rate is not a tracking rate."""
    if runtime.empty:
        return runtime, []
    work = sum(np.nan_to_num(runtime[c].to_numpy(dtype=float))
               for c in ("render", "estimate") if c in runtime.columns)
    idle = np.asarray(work) < NO_WORK_MS if np.ndim(work) else np.ones(len(runtime), bool)
    return runtime[~idle], list(runtime.index[idle])


def speed_vs_paper(episodes: "pandas.DataFrame", bench: "pandas.DataFrame") -> "pandas.DataFrame":
    """Fig. 4c beside the paper: per-step milliseconds of the voxel render, the trackers and the
    full control step, from this report's episodes (median of the per-episode medians, in the
    pool's single-threaded workers) and from the newest ``navbench bench`` run (per component,
    one process), next to the paper's GPU figures."""
    import pandas as pd

    from navbench.paper import PAPER_FIGURES

    def ep(est: str, col: str) -> float:
        if episodes.empty:
            return float("nan")
        v = episodes.loc[episodes["estimator"] == est, col].to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        return float(np.median(v)) if v.size else float("nan")

    latest = {}
    if bench is not None and not bench.empty:
        b = bench[bench["run_id"] == bench["run_id"].max()]
        latest = {(m, d): v for m, d, v in zip(b["metric"], b["device"], b["value"])}

    def bn(metric: str) -> float:
        return float(latest.get((metric, "cpu"), np.nan))

    ours_step = ep("ours", "step_ms")
    rows = [
        ("voxel map render (one image)", ep("ours", "render_ms"), bn("render_ms_half"), bn("render_ms_paper"),
         PAPER_FIGURES["voxel_render_ms"]),
        ("tracking step, ours (render included)", ep("ours", "render_ms") + ep("ours", "estimate_ms"),
         bn("track_ms_ours_half"), bn("track_ms_ours_paper"), PAPER_FIGURES["ours_track_ms"]),
        ("tracking step, emission", ep("emission", "render_ms") + ep("emission", "estimate_ms"),
         bn("track_ms_emission_half"), bn("track_ms_emission_paper"), PAPER_FIGURES["emission_track_ms"]),
        ("full step, ours + control (ms)", ours_step, bn("control_step_ms_half"),
         bn("control_step_ms_paper"), PAPER_FIGURES["control_step_ms"]),
        ("full step rate, ours + control (Hz)", 1000.0 / ours_step if ours_step > 0 else np.nan,
         bn("control_step_hz_half"), bn("control_step_hz_paper"), PAPER_FIGURES["control_step_hz"]),
    ]
    return pd.DataFrame(rows, columns=["per step", "navbench episodes (workers, run's camera)",
                                       "navbench bench, half camera", "navbench bench, paper camera",
                                       "paper (GPU)"]).set_index("per step")


def measurement_conditions(episodes: "pandas.DataFrame", runs: "pandas.DataFrame | None") -> str:
    """Where and how this report's episodes were timed: the camera (with its resolution), the
    worker setting and the CPU of the runs that stored them (``runs``: the runs table)."""
    from navbench.geometry import CAMERAS

    if runs is None or runs.empty or episodes is None or episodes.empty or "run_id" not in episodes.columns:
        return ""
    used = runs[runs["id"].isin(set(int(r) for r in episodes["run_id"]))]
    cams, workers = set(), set()
    for cfg in used["config"]:
        cfg = cfg if isinstance(cfg, dict) else {}
        cam = cfg.get("camera")
        if cam:
            c = CAMERAS.get(cam)
            cams.add(f"{cam} ({c.width} x {c.height})" if c is not None else str(cam))
        if cfg.get("workers") is not None:
            n = int(cfg["workers"])
            workers.add("one worker process per CPU" if n == 0 else
                        f"{n} worker process{'es' if n > 1 else ''}" + (" (in the run's process)" if n == 1 else ""))
    parts = []
    if cams:
        parts.append("camera " + ", ".join(sorted(cams)))
    if workers:
        parts.append(" or ".join(sorted(workers)))
    cpus = sorted(set(used["cpu"].dropna().astype(str))) if "cpu" in used.columns else []
    if cpus:
        parts.append("CPU " + "; ".join(cpus))
    return "; ".join(parts)


def section_speed_vs_paper(page: Any, episodes: "pandas.DataFrame", bench: "pandas.DataFrame",
                           runs: "pandas.DataFrame | None" = None) -> None:
    """The Fig. 4c table beside the paper's numbers, with the conditions stated (``runs``: the
    runs table, for the episodes' camera, workers and CPU)."""
    from navbench.paper import PAPER_HARDWARE

    t = speed_vs_paper(episodes, bench)
    from navbench.report.display import by_rows

    page.table(t, "runtime_vs_paper", "Fig. 4c beside the paper: median milliseconds per step "
               "(last row: steps per second); – where not measured", index=True, digits=4, display=by_rows(t))
    measured = measurement_conditions(episodes, runs)
    if measured:
        page.p(f"The episodes of this report were timed with: {measured}.")
    page.note("Conditions: the episode columns are per-step medians recorded inside the "
              "navigation workers, each worker a process run single-threaded (numba and torch on "
              "one thread, one process per core), on the run's camera, while the other workers "
              "share the machine; the bench columns are `navbench bench`'s per-component speed "
              "(its newest run in this database; empty until one ran), one process, warm-up "
              f"excluded. The paper's figures are from a GPU ({PAPER_HARDWARE}); navbench's from "
              "the CPU unless the bench says cuda.")


def fig3_episodes(eps: "pandas.DataFrame", tasks_per_level: int) -> "pandas.DataFrame":
    """The episodes Fig. 3 draws for one level: every estimator and noise of the run on the same
    few tasks (the lowest seed), the tasks where most episodes failed first (so the ablations'
    drift into walls shows), then by task id; only episodes with a stored trajectory."""
    e = eps[eps["traj_key"].notna()]
    if e.empty:
        return e
    e = e[e["seed"] == e["seed"].min()]
    fails = (~e["success"].astype(bool)).groupby(e["task_id"]).sum()
    chosen = sorted(fails.index, key=lambda t: (-int(fails[t]), int(t)))[:tasks_per_level]
    return e[e["task_id"].isin(chosen)]


def draw_fig3(fig, level, tasks, panels: dict, planning_slice=None) -> None:
    """One top view per noise level (``panels``: noise -> list of ``(variant, trajectory dict)``
    with ``true_poses``, ``est_poses``, ``target``, optional ``plan`` and ``failed``), each with
    the learned planning slice, the planned paths and every estimator's true (solid) and
    inferred (dashed) path; a shared legend."""
    from matplotlib.lines import Line2D

    from navbench.report.plots import estimator_colour, plot_level_runs

    axes = np.atleast_1d(fig.subplots(1, max(len(panels), 1)))
    variants: dict[str, str] = {}
    for ax, (noise, runs) in zip(axes, panels.items()):
        trajs = [tr for _, tr in runs]
        colours = [estimator_colour(v, i) for i, (v, _) in enumerate(runs)]
        plans, seen = [], set()
        for tr in trajs:
            key = tuple(np.round(np.asarray(tr["true_poses"], float)[0, :2], 6))
            if tr.get("plan") is not None and len(tr["plan"]) and key not in seen:
                seen.add(key)
                plans.append(tr["plan"])
        plot_level_runs(ax, level, tasks, trajs, colours=colours, plans=plans,
                        planning_slice=planning_slice, legend=False)
        ax.set_title(f"{level.name}, {noise}" if "noise" in str(noise) else f"{level.name}, {noise} noise",
                     fontsize=10)
        for (v, _), c in zip(runs, colours):
            variants.setdefault(v, c)
    handles = [Line2D([], [], color=c, linewidth=1.6, label=v) for v, c in variants.items()]
    handles += [Line2D([], [], color="black", linewidth=1.4, label="true path"),
                Line2D([], [], color="black", linewidth=1.0, linestyle="--", label="inferred path"),
                Line2D([], [], color="black", linewidth=1.8, linestyle=(0, (1, 1.5)), label="planned path"),
                Line2D([], [], color="black", marker="X", markersize=9, linestyle="none",
                       markeredgecolor="white", label="failed episode's end")]
    if planning_slice is not None:
        from matplotlib.patches import Patch

        from navbench.report.plots import SLICE_COLOUR

        handles.append(Patch(facecolor=SLICE_COLOUR[:3] + (0.3,), edgecolor=SLICE_COLOUR[:3],
                             label="learned planning slice (band)"))
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=8,
               bbox_to_anchor=(0.5, -0.02))
    fig.subplots_adjust(bottom=0.16)


def level_runs_figure(page: Any, name: str, level, tasks, eps: "pandas.DataFrame",
                      load_trajectory, load_map, tasks_per_level: int) -> None:
    """Fig. 3 for one level: :func:`fig3_episodes` loaded and drawn by :func:`draw_fig3`."""
    from navbench.errors import NavbenchError

    chosen = fig3_episodes(eps, tasks_per_level) if load_trajectory is not None and not eps.empty \
        else eps.iloc[:0] if not eps.empty else eps
    panels: dict[str, list] = {}
    failed_loads = 0
    if len(chosen):
        chosen = chosen.assign(variant=estimator_variants(chosen))
        order = sorted(range(len(chosen)), key=lambda i: (
            _order_key(chosen["noise"].iloc[i], NOISE_ORDER), int(chosen["task_id"].iloc[i]),
            _order_key(chosen["estimator"].iloc[i], ESTIMATOR_ORDER)))
        several = "conditions" in chosen.columns and chosen["conditions"].nunique() > 1
        for _, e in chosen.iloc[order].iterrows():
            try:
                tr = dict(load_trajectory(e["traj_key"]))
            except (NavbenchError, OSError, KeyError, ValueError):
                failed_loads += 1
                continue
            tr["failed"] = not bool(e["success"])
            panel = (f"{e['noise']} noise, {short_conditions(e['conditions'])}" if several
                     else str(e["noise"]))  # one panel per noise and conditions
            panels.setdefault(panel, []).append((e["variant"], tr))
    if failed_loads:
        page.note(f"Level {name}: {failed_loads} trajectory artifact(s) unavailable")
    planning_slice, slice_note = None, ""
    if load_map is not None and not eps.empty and eps["map_key"].notna().any():
        key = eps["map_key"].dropna().mode().iloc[0]
        try:
            planning_slice = load_map(key).occupancy_slice()
        except Exception as err:  # a map that cannot be loaded or sliced is a note
            slice_note = f"; learned planning slice unavailable ({type(err).__name__})"
    if not panels:
        panels = {"": []}
    ntasks = 0 if tasks is None else len(tasks)
    shown = sorted({int(t) for t in chosen["task_id"]}) if len(chosen) else []
    page.figure(lambda fig: draw_fig3(fig, level, tasks, panels, planning_slice),
                f"{name}: top view, {ntasks} task{'' if ntasks == 1 else 's'} (dots: starts, crosses: targets); tasks "
                f"{', '.join(map(str, shown)) or 'none'} by every estimator at each noise level "
                f"(the tasks with the most failures first; seed {int(chosen['seed'].min()) if len(chosen) else 0}); "
                "magenta: the learned map's band slice the planner reads" + slice_note
                + (f"; conditions: {eps['conditions'].iloc[0]}"
                   if "conditions" in eps.columns and eps["conditions"].nunique() == 1 else ""),
                (6.0 * len(panels), 6.2))
