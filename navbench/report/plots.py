"""Report figures. Every function draws into the matplotlib axis it is given; none creates a
figure or a file (the report owns both).

Inputs are plain tables and arrays: a score table (:func:`navbench.results.score.summarise`),
value arrays per label, a level, trajectory dicts ``{"true_poses": (T + 1, 3),
"est_poses": (T + 1, 3), "target": (2,)}`` in world metres.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from navbench.geometry import AGENT_LENGTH
from navbench.nav.timing import TIMING_KEYS
from navbench.results.score import ESTIMATOR_ORDER, NOISE_ORDER, _order_key

if TYPE_CHECKING:  # pragma: no cover
    import pandas

    from navbench.level import Level

#: Paper Fig. 5a, average SPL over six environments.
PAPER_SPL: dict[tuple[str, str], float] = {
    ("low", "ours"): 0.92, ("low", "no-map"): 0.61, ("low", "dynamics"): 0.61,
    ("mid", "ours"): 0.79, ("mid", "no-map"): 0.51, ("mid", "dynamics"): 0.52,
    ("high", "ours"): 0.46, ("high", "no-map"): 0.37, ("high", "dynamics"): 0.33,
}
#: Bar colour of each per-step timing component (:data:`navbench.nav.timing.TIMING_KEYS`).
COMPONENT_COLOURS = {"sim": "#9e9e9e", "render": "#1f77b4", "estimate": "#d62728",
                     "plan": "#2ca02c", "control": "#ff7f0e"}
_ESTIMATOR_COLOURS = {"ours": "#d62728", "no-map": "#1f77b4", "dynamics": "#7f7f7f",
                      "emission": "#9467bd", "gt": "#2ca02c"}
_NOISE_STYLES = {"none": ":", "tracking": "-", "low": "-", "mid": "--", "high": "-."}


def estimator_colour(label: str, index: int = 0) -> str:
    """A stable colour per estimator name (variants ``name{...}`` share their base's family)."""
    base = label.split("{")[0]
    if base in _ESTIMATOR_COLOURS and "{" not in label:
        return _ESTIMATOR_COLOURS[base]
    import matplotlib as mpl

    return mpl.colormaps["tab10"]((index + 3) % 10)


def noise_linestyle(noise: str) -> str:
    return _NOISE_STYLES.get(noise, "-")


def plot_spl(ax, table: "pandas.DataFrame", level: str = "all", paper: bool = True) -> None:
    """Fig. 5a as grouped bars: SPL per noise level (groups) and estimator (bars), with the 95 %
    bootstrap interval as error bars and the paper's values as black markers."""
    t = table[table["level"] == level]
    noises = sorted(t["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER))
    ests = sorted(t["estimator"].unique(),
                  key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
    width = 0.8 / max(len(ests), 1)
    x = np.arange(len(noises))
    paper_drawn = False
    for i, est in enumerate(ests):
        vals, lo, hi = [], [], []
        for n in noises:
            r = t[(t["estimator"] == est) & (t["noise"] == n)]
            if len(r):
                vals.append(r["spl"].iloc[0])
                lo.append(r["spl"].iloc[0] - r["spl_ci_low"].iloc[0])
                hi.append(r["spl_ci_high"].iloc[0] - r["spl"].iloc[0])
            else:
                vals.append(np.nan); lo.append(0.0); hi.append(0.0)
        pos = x - 0.4 + width * (i + 0.5)
        ax.bar(pos, vals, width * 0.9, yerr=[lo, hi], capsize=3, label=est,
               color=estimator_colour(est, i), edgecolor="black", linewidth=0.4)
        if paper:
            pv = [PAPER_SPL.get((n, est), np.nan) for n in noises]
            if np.isfinite(pv).any():
                ax.plot(pos, pv, linestyle="none", marker="_", markersize=14, markeredgewidth=2,
                        color="black", label=None if paper_drawn else "paper")
                paper_drawn = True
    ax.set_xticks(x)
    ax.set_xticklabels(noises)
    ax.set_xlabel("noise")
    ax.set_ylabel("SPL")
    ax.set_ylim(0, 1.05)
    ax.set_title(f"SPL by estimator and noise ({'pooled over levels' if level == 'all' else level})")
    ax.grid(axis="y", alpha=0.3)
    if ests:
        ax.legend(fontsize=8, ncol=2)


def plot_paired_differences(ax, paired: "pandas.DataFrame", paper_margin=None) -> None:
    """The paper's claim: ``reference - other`` SPL difference per noise level (groups) and
    comparison (points), with its 95 % interval as error bars, a zero line, and the paper's
    margin ``paper_margin(noise, other)`` (a callable, or None) as black ticks.

    ``paired``: rows of :func:`navbench.results.score.paired_differences` for one level.
    """
    noises = sorted(paired["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER))
    others = sorted(paired["other"].unique(),
                    key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
    x = np.arange(len(noises))
    width = 0.8 / max(len(others), 1)
    drawn = False
    for i, other in enumerate(others):
        pos = x - 0.4 + width * (i + 0.5)
        vals, lo, hi, paper = [], [], [], []
        for n in noises:
            r = paired[(paired["noise"] == n) & (paired["other"] == other)]
            v = float(r["spl_diff"].iloc[0]) if len(r) and r["pairs"].iloc[0] else np.nan
            vals.append(v)
            lo.append(v - float(r["spl_diff_ci_low"].iloc[0]) if np.isfinite(v) else 0.0)
            hi.append(float(r["spl_diff_ci_high"].iloc[0]) - v if np.isfinite(v) else 0.0)
            paper.append(paper_margin(n, other) if paper_margin else np.nan)
        label = str(paired.loc[paired["other"] == other, "comparison"].iloc[0])
        ax.errorbar(pos, vals, yerr=[lo, hi], fmt="o", capsize=4, color=estimator_colour(other, i),
                    label=label)
        if np.isfinite(paper).any():
            ax.plot(pos, paper, linestyle="none", marker="_", markersize=16, markeredgewidth=2,
                    color="black", label=None if drawn else "paper")
            drawn = True
    ax.axhline(0.0, color="black", linewidth=0.8)
    ax.set_xticks(x)
    ax.set_xticklabels(noises)
    ax.set_xlabel("noise")
    ax.set_ylabel("SPL difference")
    ax.set_title("ours − ablation on the same tasks and seeds")
    ax.grid(axis="y", alpha=0.3)
    if others:
        ax.legend(fontsize=8)


def empirical_cdf(values) -> tuple[np.ndarray, np.ndarray]:
    """Sorted finite values ``x`` and ``F(x) = (rank) / n`` in [1/n, 1]."""
    x = np.sort(np.asarray(values, dtype=float)[np.isfinite(np.asarray(values, dtype=float))])
    return x, np.arange(1, x.size + 1) / max(x.size, 1)


def plot_cdf(ax, groups: Mapping[str, Sequence[float]], xlabel: str, vline: float | None = None,
             vline_label: str | None = None, styles: Mapping[str, tuple[str, str]] | None = None) -> None:
    """Fig. 4a/b: the empirical CDF (fraction of trajectories with RMSE <= x) of each group.

    ``groups`` maps a label to its values; ``styles`` optionally maps a label to (colour,
    linestyle). A log x axis is used when the values span more than two decades.
    """
    finite = [np.asarray(v, float)[np.isfinite(np.asarray(v, float))] for v in groups.values()]
    allv = np.concatenate(finite) if finite else np.zeros(0)
    for i, (label, vals) in enumerate(groups.items()):
        x, y = empirical_cdf(vals)
        if x.size == 0:
            continue
        colour, ls = (styles or {}).get(label, (estimator_colour(label, i), "-"))
        ax.step(np.concatenate([[x[0]], x]), np.concatenate([[0.0], y]), where="post",
                color=colour, linestyle=ls, label=f"{label} (n={x.size})")
    pos = allv[allv > 0]
    if pos.size and pos.max() / pos.min() > 100:
        ax.set_xscale("log")
    if vline is not None:
        ax.axvline(vline, color="black", linewidth=0.8, linestyle=":", label=vline_label)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fraction of trajectories")
    ax.grid(alpha=0.3)
    if groups:
        ax.legend(fontsize=7, loc="lower right")


def plot_loc_cdf(ax, groups: Mapping[str, Sequence[float]], styles=None) -> None:
    """Fig. 4a: location RMSE CDF with the paper's vertical line at 0.5 x agent size."""
    plot_cdf(ax, groups, "location RMSE (m)", vline=0.5 * AGENT_LENGTH,
             vline_label="0.5 x agent size", styles=styles)
    ax.set_title("Location RMSE")


def plot_rot_cdf(ax, groups: Mapping[str, Sequence[float]], styles=None) -> None:
    """Fig. 4b: orientation RMSE CDF."""
    plot_cdf(ax, groups, "orientation RMSE (deg)", styles=styles)
    ax.set_title("Orientation RMSE")


def plot_step_runtime(ax, runtime: "pandas.DataFrame") -> None:
    """Fig. 4c: per-step time by component as stacked horizontal bars, one per estimator.

    ``runtime``: index = estimator labels, columns = a subset of
    :data:`~navbench.nav.timing.TIMING_KEYS` (median ms per step) and optionally ``step_ms``
    (the median total, annotated with its rate in Hz).
    """
    labels = list(runtime.index)
    y = np.arange(len(labels))
    left = np.zeros(len(labels))
    for comp in TIMING_KEYS:
        if comp not in runtime.columns:
            continue
        vals = np.nan_to_num(runtime[comp].to_numpy(dtype=float))
        if not vals.any():
            continue
        ax.barh(y, vals, left=left, color=COMPONENT_COLOURS[comp], label=comp, edgecolor="white",
                linewidth=0.5)
        left += vals
    totals = runtime["step_ms"].to_numpy(dtype=float) if "step_ms" in runtime.columns else left
    for yi, total, stacked in zip(y, totals, left):
        if np.isfinite(total) and total > 0:
            ax.text(max(stacked, total) * 1.02, yi, f"{total:.1f} ms ({1000 / total:.1f} Hz)",
                    va="center", fontsize=8)
    ax.set_yticks(y)
    ax.set_yticklabels(labels)
    ax.invert_yaxis()
    xmax = np.nanmax(np.concatenate([left, np.nan_to_num(totals)])) if labels else 1.0
    ax.set_xlim(0, max(xmax, 1e-3) * 1.45)
    ax.set_xlabel("median time per step (ms)")
    ax.set_title("Per-step runtime by component")
    ax.grid(axis="x", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:  # no bar when every component time is 0 or missing
        ax.legend(fontsize=8, loc="lower right")


def draw_level_outline(ax, level: "Level") -> None:
    """Fallback top view: every prism of :func:`navbench.level.prisms`, coloured by height."""
    import matplotlib as mpl
    from matplotlib.patches import Polygon

    from navbench.level import prisms

    p = prisms(level)
    cm = mpl.colormaps["viridis"]
    for i in range(len(p)):
        colour = "#3a3a3a" if p.is_wall[i] else cm(p.height[i] / max(level.height, 1e-9))
        ax.add_patch(Polygon(p.polygon(i), closed=True, facecolor=colour, edgecolor="black",
                             linewidth=0.3))
    ax.set_xlim(0, level.width)
    ax.set_ylim(0, level.depth)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(level.name)


#: Colour of the learned planning slice in Fig. 3 (RGB, alpha for the legend patch).
SLICE_COLOUR = (0.89, 0.12, 0.76, 0.5)


def plot_planning_slice(ax, occ2d, xs, ys, colour=SLICE_COLOUR[:3], alpha: float = 0.3,
                        zorder: float = 4.0) -> None:
    """The learned map's planning slice (``occ2d (nx, ny)`` bool over cell centres ``xs``,
    ``ys``, world metres): what the planner believes is occupied, as a translucent magenta fill
    with its outline (:data:`SLICE_COLOUR`), over the true level. ``colour`` (RGB), the fill's
    ``alpha`` and ``zorder`` let other cell masks reuse it (the report's explored cells)."""
    occ = np.asarray(occ2d, bool)
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    dx = (xs[-1] - xs[0]) / max(len(xs) - 1, 1)
    dy = (ys[-1] - ys[0]) / max(len(ys) - 1, 1)
    rgba = np.zeros(occ.T.shape + (4,))
    rgba[occ.T] = tuple(colour[:3]) + (alpha,)
    ax.imshow(rgba, origin="lower", interpolation="nearest", zorder=zorder,
              extent=(xs[0] - dx / 2, xs[-1] + dx / 2, ys[0] - dy / 2, ys[-1] + dy / 2))
    if occ.any() and not occ.all() and min(occ.shape) > 1:
        ax.contour(xs, ys, occ.T.astype(float), levels=[0.5], colors=[tuple(colour[:3])],
                   linewidths=0.8, zorder=zorder + 0.5)


def plot_level_runs(ax, level: "Level", tasks: "pandas.DataFrame | None" = None,
                    trajectories: Sequence[Mapping[str, Any]] = (),
                    labels: Sequence[str] | None = None, colours: Sequence[str] | None = None,
                    plans: Sequence[Any] = (), planning_slice: tuple | None = None,
                    legend: bool = True, free_space: bool = True) -> None:
    """Fig. 3: the level's top view, its tasks (start dots, target crosses) and trajectories
    (true path solid, estimated path dashed, in the same colour; target star; a black cross
    where a trajectory marked ``"failed": True`` ended).

    ``colours``: one per trajectory (default: tab10). ``plans``: planned paths ``(K, 2)`` drawn
    dotted black. ``planning_slice``: ``(occ2d, xs, ys)`` of the learned map, drawn over the
    level (:func:`plot_planning_slice`). ``free_space``: shade the free cells green (as
    :func:`navbench.levelview.draw_level`). Uses that function when available, else
    :func:`draw_level_outline`.
    """
    try:
        from navbench.levelview import draw_level
    except ImportError:  # pragma: no cover - levelview is part of the package
        draw_level_outline(ax, level)
    else:
        draw_level(ax, level, colorbar=False, free_space=free_space)
    if planning_slice is not None:
        plot_planning_slice(ax, *planning_slice)
    for i, plan in enumerate(plans):
        plan = np.asarray(plan, float)
        if plan.ndim == 2 and len(plan):
            ax.plot(plan[:, 0], plan[:, 1], color="black", linestyle=(0, (1, 1.5)), linewidth=1.8,
                    zorder=7.5, label="planned path" if i == 0 else None)
    if tasks is not None and len(tasks):
        ax.scatter(tasks["start_x"], tasks["start_y"], s=6, color="#555555", zorder=5,
                   label=f"task starts ({len(tasks)})")
        ax.scatter(tasks["target_x"], tasks["target_y"], s=8, marker="x", linewidths=0.6,
                   color="#555555", zorder=5, label="task targets")
    import matplotlib as mpl

    cmap = mpl.colormaps["tab10"]
    for i, tr in enumerate(trajectories):
        colour = colours[i] if colours is not None and i < len(colours) else cmap((i + 3) % 10)
        true = np.asarray(tr["true_poses"], float)
        est = np.asarray(tr["est_poses"], float)
        label = labels[i] if labels is not None and i < len(labels) else f"run {i + 1}"
        ax.plot(true[:, 0], true[:, 1], color=colour, linewidth=1.4, zorder=6, label=f"{label}: truth")
        ax.plot(est[:, 0], est[:, 1], color=colour, linewidth=1.0, linestyle="--", zorder=7,
                label=f"{label}: inferred")
        ax.plot(true[0, 0], true[0, 1], marker="o", color=colour, markersize=5, zorder=8)
        target = tr.get("target")
        if target is not None:
            ax.plot(target[0], target[1], marker="*", color=colour, markersize=10,
                    markeredgecolor="black", markeredgewidth=0.5, zorder=8)
        if tr.get("failed"):
            ax.plot(true[-1, 0], true[-1, 1], marker="X", color="black", markersize=10,
                    markeredgecolor="white", markeredgewidth=0.8, zorder=9)
    if legend and ((tasks is not None and len(tasks)) or len(trajectories)):
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
