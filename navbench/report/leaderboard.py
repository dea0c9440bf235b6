"""Report sections of issue 35: the leaderboard (every estimator of the selection, one row each,
success rate and SPL with their intervals per noise, the paper's Fig. 5a SPL beside navbench's)
and the comparisons named with ``navbench report --pair A:B`` (:mod:`navbench.results.compare`).

Like :mod:`navbench.report.claim`, each ``section_*`` function appends to the report
page it is given and reads plain frames; it does not import the report.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from navbench.results.score import ESTIMATOR_ORDER, NOISE_ORDER, _order_key, conditions_in

if TYPE_CHECKING:  # pragma: no cover
    import pandas

LONG_COLUMNS = ["conditions", "goal", "estimator", "noise", "episodes", "success_rate", "success_rate_ci_low",
                "success_rate_ci_high", "spl", "spl_ci_low", "spl_ci_high", "paper_spl", "rank"]


NBSP = "\u00a0"


def _ci(v, lo, hi, d: int = 2) -> str:
    """``"0.88 [0.47, 1.00]"`` with no-break spaces (one cell never wraps inside a number)."""
    return "–" if v is None or not np.isfinite(v) else f"{v:.{d}f} [{lo:.{d}f}, {hi:.{d}f}]".replace(" ", NBSP)


def leaderboard(table: "pandas.DataFrame") -> "pandas.DataFrame":
    """One row per (conditions, goal, estimator, noise) of the pooled (``level = "all"``) rows of
    a score table (:func:`navbench.results.score.summarise`), with the paper's Fig. 5a SPL
    (``paper_spl``, NaN where the paper has none) and ``rank``: 1 for the estimator with the
    highest SPL averaged over the noise levels it ran at, within its conditions and goal."""
    import pandas as pd

    from navbench.report.plots import PAPER_SPL

    t = table[table["level"] == "all"]
    if t.empty:
        return pd.DataFrame(columns=LONG_COLUMNS)
    goal = t["goal"] if "goal" in t.columns else t["level"].map(lambda _: "point")
    rows = []
    for r, g in zip(t.itertuples(), goal):
        paper = PAPER_SPL.get((r.noise, r.estimator)) if g == "point" else None
        rows.append({"conditions": r.conditions, "goal": g, "estimator": r.estimator, "noise": r.noise,
                     "episodes": int(r.episodes), "success_rate": r.success_rate,
                     "success_rate_ci_low": r.success_rate_ci_low, "success_rate_ci_high": r.success_rate_ci_high,
                     "spl": r.spl, "spl_ci_low": r.spl_ci_low, "spl_ci_high": r.spl_ci_high,
                     "paper_spl": np.nan if paper is None else paper})
    f = pd.DataFrame(rows)
    mean = f.groupby(["conditions", "goal", "estimator"])["spl"].mean()
    f["rank"] = 0
    for (conds, g), m in mean.groupby(level=["conditions", "goal"]):
        order = sorted(m.index, key=lambda k: (-m[k], _order_key(k[2].split("{")[0], ESTIMATOR_ORDER), k[2]))
        for i, k in enumerate(order):
            f.loc[(f["conditions"] == conds) & (f["goal"] == g) & (f["estimator"] == k[2]), "rank"] = i + 1
    f = f.sort_values(["conditions", "goal", "rank"], kind="stable")
    f = f.iloc[sorted(range(len(f)), key=lambda i: (f["conditions"].iloc[i], f["goal"].iloc[i], f["rank"].iloc[i],
                                                     _order_key(f["noise"].iloc[i], NOISE_ORDER)))]
    return f[LONG_COLUMNS].reset_index(drop=True)


def leaderboard_display(board: "pandas.DataFrame") -> "pandas.DataFrame":
    """The page's view of one (conditions, goal) of :func:`leaderboard`: a row per estimator (in
    rank order), per noise the columns ``SR [95 %]``, ``SPL [95 %]`` and, where the paper gives
    one for some estimator, ``paper SPL`` right after navbench's."""
    import pandas as pd

    noises = sorted(board["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER))
    cells = {(r.estimator, r.noise): r for r in board.itertuples()}
    ests = list(dict.fromkeys(board["estimator"]))
    cols, data = [], {e: [] for e in ests}
    for n in noises:
        paper = board.loc[board["noise"] == n, "paper_spl"].notna().any()
        cols += [(f"noise {n}", "SR [95 %]"), (f"noise {n}", "SPL [95 %]")] + \
            ([(f"noise {n}", "paper SPL")] if paper else [])
        for e in ests:
            r = cells.get((e, n))
            data[e] += ["–", "–"] if r is None else [
                _ci(r.success_rate, r.success_rate_ci_low, r.success_rate_ci_high),
                _ci(r.spl, r.spl_ci_low, r.spl_ci_high)]
            if paper:
                data[e].append("–" if r is None or not np.isfinite(r.paper_spl) else f"{r.paper_spl:.2f}")
    columns = pd.MultiIndex.from_tuples(cols, names=[None, "estimator"])
    return pd.DataFrame([data[e] for e in ests], index=pd.Index(ests), columns=columns)


def section_leaderboard(page: Any, table: "pandas.DataFrame | None", preset: str) -> None:
    """Every estimator of the selection ranked, SR and SPL per noise, the paper's SPL beside;
    ``leaderboard.csv`` holds every row."""
    if table is None or table.empty:
        return
    board = leaderboard(table)
    if board.empty:
        return
    page.csv(board, "leaderboard")
    several = len(conditions_in(table)) > 1
    for (conds, goal), b in board.groupby(["conditions", "goal"], sort=False):
        caption = (f"Leaderboard, {goal} goals: every estimator, ranked by its SPL averaged over the noise "
                   f"levels it ran at; pooled over levels; success rate [95% exact interval], SPL [95% BCa "
                   f"bootstrap interval stratified by level], the paper's Fig. 5a SPL beside navbench's; "
                   f"scoring preset '{preset}'" + (f"; conditions: {conds}" if several else ""))
        _figure_table(page, leaderboard_display(b), caption, "leaderboard.csv", index=True)


def _figure_table(page: Any, display: "pandas.DataFrame", caption: str, csv: str, index: bool = False) -> None:
    """Show ``display`` (strings) on the page, captioned, linking ``csv`` (written by the caller)."""
    import html

    body = display.to_html(index=index, border=0, classes="tbl", escape=True)
    page.sections.append(f'<figure class="table"><figcaption>{html.escape(caption)} (<a href="{html.escape(csv)}">'
                         f"{html.escape(csv)}</a>)</figcaption>{body}</figure>")


def section_compare(page: Any, episodes: "pandas.DataFrame", pairs, n_boot: int, seed: int) -> None:
    """The comparisons named with ``report --pair A:B``: B - A on the same episodes
    (:func:`navbench.results.compare.estimator_pairs`), one table, ``comparisons.csv``."""
    import pandas as pd

    from navbench.results.compare import display_rows, estimator_pairs

    if not pairs:
        return
    page.h2("Comparisons (report --pair)", "compare")
    if episodes is None or episodes.empty:
        page.note("No navigation episodes stored yet.")
        return
    t = estimator_pairs(episodes, pairs, n_boot=n_boot, seed=seed)
    page.p("Each row: B − A, the mean over pairs of B's minus A's value for the two estimators' episodes "
           "on the same level, map, noise, simulator conditions, task and seed (navbench compare "
           "--pair A:B). Intervals: 95 % BCa bootstrap resampling pairs within each level; success also "
           "the discordant pairs (only A / only B succeeded) and the exact McNemar p. Episodes "
           "without a partner are left out and counted.")
    several = t["conditions"].nunique() > 1
    preset = t["preset"].iloc[0] if len(t) else "paper"
    page.csv(t, "comparisons")
    for part, what in (("success", "success rate (SR)"), ("path", "SPL, SoftSPL and location RMSE")):
        head, rows = display_rows(t, conditions=several, part=part, repeat_pooled=False)
        rows = [[c if j < 3 else c.replace(" ", NBSP) for j, c in enumerate(r)] for r in rows]  # numbers stay whole
        _figure_table(page, pd.DataFrame(rows, columns=head),
                      f"B − A per comparison, level and noise: {what}; scoring preset '{preset}'", "comparisons.csv")
