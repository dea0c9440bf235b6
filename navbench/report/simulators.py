"""The report's "Simulators" section: one benchmark version on two backends, side by side (issue 37 §4).

Results of two simulators are two benchmark versions (``navbench-1`` and ``navbench-1+vizdoom``,
:func:`navbench.benchmark.sim_version`) and are never pooled; the report's main sections show
one of them. This section sets the others beside it:

* **the sides**: the report's selection at its version (the *report side*), and

  - every other simulator's episodes of the same base version in the report's selection (one
    database holding ``navbench-1`` and ``navbench-1+vizdoom``; the same ``--run`` and grid
    cells apply), and/or
  - ``report --b-db URL``: another database's episodes of the same base version (all its runs),
    on another simulator where it holds one, else on the report's own (two runs of one backend);

* **the pairing**: ``navbench compare --b-db``'s, exactly
  (:func:`navbench.results.compare.side_pairs`): episodes pair on level, noise, task (start and
  goal) and seed, estimator by estimator; both sides are scored under the report's preset; every
  difference is **other − reference** (the reference simulator, pymunk, is the first side
  whatever the report's version), with the 95 % intervals of :mod:`navbench.results.paired`
  (BCa bootstrap stratified by level, the report's ``--boot`` resamples and seed);
* **the table** (:func:`simulator_table`): per estimator and noise, pooled over the levels both
  sides hold: the pairs (and each side's episodes without a partner), success rate and SPL on
  each backend over the paired episodes, the paper's SPL (Fig. 5a, the values the report's
  leaderboard sets beside navbench's; point goals only), each backend's SPL minus the paper's,
  and the paired differences of success and SPL with their intervals. The CSV
  (``simulators.csv``) also has each level's rows;
* **the claim on each backend** (:func:`claim_by_backend`): ``ours - ablation`` SPL on each
  backend's own episodes (the report's claim section's pairing and intervals), beside the
  paper's margin (``simulators_claim.csv``).

Sides that share no paired episode get a one-line note instead of a table.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    import pandas

    from navbench.results.db import ResultsDB

#: Columns of :func:`simulator_table` beyond :data:`navbench.results.paired.COLUMNS` and ``preset``.
EXTRA_COLUMNS = ["paper_spl"]


@dataclass
class Side:
    """One backend's episodes: ``frame`` (one benchmark ``version``), ``label`` (the column
    title: the simulator, or where the episodes come from when both sides ran one simulator)
    and ``source`` (the database and selection in words)."""

    label: str
    version: str
    frame: "pandas.DataFrame"
    source: str


def simulator_table(reference: "pandas.DataFrame", other: "pandas.DataFrame", preset: str,
                    n_boot: int | None = None, seed: int = 0, method: str = "bca") -> "pandas.DataFrame":
    """``other - reference`` per estimator, level (and pooled, ``level == "all"``) and noise:
    :func:`navbench.results.compare.side_pairs`'s table (the pairing and intervals of ``navbench
    compare --b-db``) with ``paper_spl``, the paper's Fig. 5a SPL of the estimator at that noise
    (NaN where the paper has none, or where the episodes are not all point-goal ones).

    ``reference``, ``other``: episodes frames of one benchmark version each
    (:func:`navbench.results.score.select_versioned`). Sides sharing no estimator are a
    :class:`~navbench.errors.ConfigError`."""
    import numpy as np

    from navbench.report.plots import PAPER_SPL
    from navbench.results.compare import side_pairs

    table = side_pairs(reference, other, preset, n_boot=n_boot, seed=seed, method=method,
                       side_a="the reference backend", side_b="the other backend")
    # a row that says nothing is a point goal (stored before image goals: apply_preset's rule)
    point = all("goal" not in f.columns or bool((f["goal"].fillna("point") == "point").all())
                for f in (reference, other))
    table["paper_spl"] = [PAPER_SPL.get((n, e.split("{")[0]), np.nan) if point else np.nan
                          for n, e in zip(table["noise"], table["estimator_a"])]
    return table


def _sim(version: str) -> str:
    from navbench.benchmark import split_version

    return split_version(version)[1]


def simulator_sides(db: "ResultsDB", version: str | None, episodes: "pandas.DataFrame", run=None,
                    cell_keys=None, b_db: "ResultsDB | None" = None) -> tuple[list[Side], list[str]]:
    """The sides of the section: ``[reference, other, ...]`` (the reference simulator's side
    first; empty when there is nothing to set beside the report's version) and notes (a
    ``--b-db`` database holding nothing of the report's base version). ``episodes``: the report's
    selection at ``version``; ``run``, ``cell_keys``: its selection, applied to the other
    simulators' episodes of ``db``."""
    from navbench.benchmark import REFERENCE_SIM, split_version
    from navbench.report.display import plural
    from navbench.results.db.resume import resolve_run_ids
    from navbench.results.score import select_versioned
    from navbench.results.versions import versions_of

    notes: list[str] = []
    if version is None or episodes.empty:
        if b_db is not None:
            notes.append("The report's selection holds no navigation episodes: nothing to set beside "
                         f"{b_db.display_url}'s.")
        return [], notes
    base, sim = split_version(version)
    raw = db.episodes_frame(run_ids=resolve_run_ids(db, run))
    if cell_keys is not None and not raw.empty:
        raw = raw[raw["cell_key"].isin(set(cell_keys))]
    here = sorted({v for v in versions_of(raw) if v != version and split_version(v)[0] == base})
    found: list[tuple[str, "pandas.DataFrame", str]] = [(version, episodes, "this database")]
    for v in here:
        frame, _, _ = select_versioned(db, run=run, cell_keys=cell_keys, benchmark_version=v)
        found.append((v, frame, "this database"))
    if b_db is not None:
        held = sorted(set(versions_of(b_db.episodes_frame())))
        same_base = [v for v in held if split_version(v)[0] == base]
        if not same_base:
            notes.append(f"--b-db {b_db.display_url} holds no episodes of {base} on any simulator (it holds "
                         f"{', '.join(held)}): results of two benchmark versions are not set side by side.")
        else:
            v = next((v for v in same_base if split_version(v)[1] != sim), same_base[0])
            frame, _, _ = select_versioned(b_db, benchmark_version=v)
            found.append((v, frame, "--b-db"))
    if len(found) == 1:
        return [], notes
    sims = [_sim(v) for v, _, _ in found]
    sides = []
    for (v, frame, where), s in zip(found, sims):
        label = s if sims.count(s) == 1 else f"{s} ({where})"
        url = db.display_url if where == "this database" else b_db.display_url
        sides.append(Side(label, v, frame, f"{v}, {plural(len(frame), 'episode')} of {url}"))
    ref = next((i for i, s in enumerate(sims) if s == REFERENCE_SIM), 0)
    return [sides[ref]] + [s for i, s in enumerate(sides) if i != ref], notes


def display_frame(table: "pandas.DataFrame", a: str, b: str) -> "pandas.DataFrame":
    """The pooled rows of a :func:`simulator_table` as the page shows them: labels, three
    decimals, differences with their 95 % interval; ``a``, ``b``: the two backends' labels."""
    import pandas as pd

    from navbench.report.leaderboard import NBSP
    from navbench.results.compare import _fmt, fmt_diff

    pooled = table[table["level"] == "all"]
    rows = []
    for r in pooled.itertuples():
        rows.append([r.estimator_a, r.noise, f"{r.pairs} ({r.unpaired_a} / {r.unpaired_b})",
                     _fmt(r.success_a), _fmt(r.success_b),
                     fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high).replace(" ", NBSP),
                     _fmt(r.spl_a), _fmt(r.spl_b), _fmt(r.paper_spl, 2),
                     "–" if r.paper_spl != r.paper_spl else
                     f"{r.spl_a - r.paper_spl:+.3f} / {r.spl_b - r.paper_spl:+.3f}".replace(" ", NBSP),
                     fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high).replace(" ", NBSP)])
    head = ["estimator", "noise", f"pairs (unpaired {a} / {b})", f"success {a}", f"success {b}",
            f"success {b} − {a} [95 %]", f"SPL {a}", f"SPL {b}", "SPL paper (Fig. 5a)",
            f"SPL − paper, {a} / {b}", f"SPL {b} − {a} [95 %]"]
    return pd.DataFrame(rows, columns=head)


def claim_by_backend(sides: list[Side], preset: str, n_boot: int, seed: int) -> "pandas.DataFrame":
    """The paper's claim on each backend: :func:`navbench.results.score.paired_differences`
    (``ours - ablation`` on each side's own episodes, the pairing of the report's claim section)
    of every side's episodes scored under ``preset``, with columns ``backend`` (the side's
    label) first and ``paper_diff`` (the paper's Fig. 5a margin) last."""
    import pandas as pd

    from navbench.report.claim import paper_difference
    from navbench.results.presets import apply_preset
    from navbench.results.score import paired_differences

    parts = []
    for side in sides:
        f = side.frame if side.frame.attrs.get("preset") == preset else apply_preset(side.frame, preset)
        t = paired_differences(f, n_boot=n_boot, seed=seed)
        parts.append(t.assign(backend=side.label))
    out = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    if out.empty:
        return out
    out["paper_diff"] = [paper_difference(n, o) for n, o in zip(out["noise"], out["other"])]
    return out[["backend"] + [c for c in out.columns if c != "backend"]]


def claim_display(claim: "pandas.DataFrame", labels: list[str]) -> "pandas.DataFrame":
    """The pooled rows of :func:`claim_by_backend` side by side: one row per (comparison, noise[,
    conditions where several]); per backend its ``ours - ablation`` SPL [95 %] and pairs; the
    paper's margin."""
    import pandas as pd

    from navbench.report.leaderboard import NBSP
    from navbench.results.compare import fmt_diff, short_label
    from navbench.results.score import ESTIMATOR_ORDER, NOISE_ORDER, _order_key

    t = claim[claim["level"] == "all"]
    several = t["conditions"].nunique() > 1
    key = ["comparison", "noise"] + (["conditions"] if several else [])
    other = dict(zip(t["comparison"], t["other"]))
    cells: dict[tuple, dict[str, str]] = {}
    for r in t.itertuples():
        k = tuple(getattr(r, c) for c in key)
        row = cells.setdefault(k, {"paper": "–" if r.paper_diff != r.paper_diff else f"{r.paper_diff:+.2f}"})
        row[r.backend] = (f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} ({r.pairs})"
                          .replace(" ", NBSP))
    order = sorted(cells, key=lambda k: (_order_key(other[k[0]].split("{")[0], ESTIMATOR_ORDER), k[0],
                                         _order_key(k[1], NOISE_ORDER)) + k[2:])
    rows = [[k[0].replace(" - ", " − "), k[1]] + ([short_label(k[2])] if several else [])
            + [cells[k].get(b, "–") for b in labels] + [cells[k]["paper"]] for k in order]
    head = ["comparison", "noise"] + (["conditions"] if several else []) + \
        [f"SPL {b} [95 %] (pairs)" for b in labels] + ["paper (Fig. 5a)"]
    return pd.DataFrame(rows, columns=head)


def section_simulators(page: Any, sides: list[Side], notes: list[str], preset: str, n_boot: int,
                       seed: int) -> bool:
    """The section (module docstring) for ``sides`` (:func:`simulator_sides`) on ``page``; False
    (nothing written) when there is no second side and no note."""
    from navbench.errors import ConfigError
    from navbench.report.leaderboard import _figure_table

    if not sides and not notes:
        return False
    one_sim = len({_sim(s.version) for s in sides}) == 1  # --b-db on the report's own simulator
    page.h2("Two databases on one simulator, side by side (report --b-db)" if sides and one_sim else
            "Simulators: the same tasks on two backends (issue 37)", "simulators")
    for n in notes:
        page.note(n)
    if not sides:
        return True
    ref = sides[0]
    page.p("Each row: one estimator at one noise level, pooled over the levels both sides ran. "
           "Episodes pair on level, noise, task (start and goal) and seed, as navbench compare --b-db; "
           "success rate and SPL are means over the paired episodes, each side scored separately "
           "(two benchmark versions are never pooled), under the scoring preset "
           f"'{preset}'. Differences are the other side − {ref.label}, with 95 % BCa bootstrap "
           "intervals resampling pairs within each level; the paper's SPL is its Fig. 5a (ViZDoom).")
    for i, other in enumerate(sides[1:]):
        name = "simulators" + (f"_{i + 1}" if i else "")
        page.p(f"{ref.label}: {ref.source}. {other.label}: {other.source}.", "meta")
        try:
            table = simulator_table(ref.frame, other.frame, preset, n_boot=n_boot, seed=seed)
        except ConfigError:  # no estimator in common
            table = None
        if table is None or not int(table.loc[table["level"] == "all", "pairs"].sum()):
            page.note(f"{ref.label} and {other.label} share no paired episodes (no common estimator, level, "
                      "noise, task and seed): nothing to compare.")
            continue
        table.insert(1, "backend_a", f"{ref.label}: {ref.version}")
        table.insert(2, "backend_b", f"{other.label}: {other.version}")
        page.csv(table, name)
        _figure_table(page, display_frame(table, ref.label, other.label),
                      f"{other.label} beside {ref.label} per estimator and noise, pooled over levels; "
                      "each level's rows in the CSV", f"{name}.csv")
    claim = claim_by_backend(sides, preset, n_boot, seed)
    if not claim.empty:
        page.csv(claim, "simulators_claim")
        _figure_table(page, claim_display(claim, [s.label for s in sides]),
                      "The paper's claim on each backend: ours − ablation SPL on each backend's own "
                      "episodes (paired on level, map, noise, task and seed, as the claim section above), "
                      "pooled over levels", "simulators_claim.csv")
    return True
