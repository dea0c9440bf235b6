"""Offline scoring: the stored episodes -> per (level, estimator, noise) metrics with intervals.

Which episodes count: every stored episode, once. The ``episodes`` table is unique on
(cell_key, task_id, seed) and inserts never overwrite, so each (cell, task, seed) contributes the
single value recorded the first time it completed (reruns skip done keys). A cell's key hashes
its task set, so ``--tasks 2`` then ``--tasks 4`` store tasks 0 and 1 under two cells: episodes
are therefore counted once per (setup, task, seed) (:func:`with_identities`: the setup is the
cell without its task set, the task is its start and target), the first stored row kept. ``run``
narrows this to the episodes given runs inserted (:mod:`navbench.results.db.resume`): a
resumed run owns only the episodes it added, so ``"latest"`` is the newest run that stored
episodes with the interrupted runs of the same configuration it resumed, and explicit ids are
literal (``"4,5,6"``).

Per group (level, estimator, noise; plus ``level = "all"`` pooled over levels):

* ``success_rate`` -- mean of the success flags;
* ``spl`` -- mean of ``s_i l_i / max(p_i, l_i)`` (eq. 8; Anderson et al. 2018, "On evaluation of
  embodied navigation agents");
* ``loc_rmse_m``, ``rot_rmse_deg`` -- median over episodes of the per-trajectory RMSE;
* ``step_ms`` -- median over episodes of the per-episode median step time; ``step_hz`` = 1000 /
  ``step_ms``, left empty where ``tracking_work`` is False (:data:`NO_WORK_MS`).

Intervals (95 %, seeded, so a score is deterministic):

* ``success_rate`` -- exact binomial (Clopper-Pearson), :func:`navbench.nav.metrics.clopper_pearson`
  (pooled rows: on the total count of successes);
* ``spl`` -- bootstrap stratified by level, BCa (:func:`navbench.nav.metrics.stratified_bootstrap_ci`,
  ``n_boot`` resamples; every resample keeps each level's episode count; a per-level row has one
  stratum);
* the medians (RMSEs, step time) -- percentile bootstrap of the group's episodes (:func:`bootstrap_ci`).

:func:`paired_differences` gives the paper's claim: ``ours - no-map`` and ``ours - dynamics`` SPL
and success on the same (condition, task, seed), with a paired bootstrap stratified by level.
An estimator run with several option sets is split into variants labelled ``name{key=value,...}``.

``setups`` counts the cells a group pools within one level: 1 unless the database holds the same
(level, estimator, noise) under several maps, task sets or episode settings (say a quick run and
a paper run). Such a row mixes experiments; :func:`mixed_setups` lists them, and ``score`` and the
report warn. Narrow with ``run`` (or keep experiments in separate databases).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from navbench.errors import DatabaseError
from navbench.nav.metrics import clopper_pearson, stratified_bootstrap_ci

if TYPE_CHECKING:  # pragma: no cover
    import pandas

    from navbench.results.db import ResultsDB

NOISE_ORDER = ("none", "tracking", "low", "mid", "high")
ESTIMATOR_ORDER = ("ours", "no-map", "dynamics", "emission", "gt")
N_BOOT = 2000
CI_LEVEL = 0.95

# (output column, episode column, statistic name)
METRICS: tuple[tuple[str, str, str], ...] = (
    ("success_rate", "success", "mean"),
    ("spl", "spl_term", "mean"),
    ("loc_rmse_m", "loc_rmse_m", "median"),
    ("rot_rmse_deg", "rot_rmse_deg", "median"),
    ("step_ms", "step_ms", "median"),
)
#: Issue 15's metrics, after the columns above: habitat's SoftSPL and the mean final distance
#: to the goal (the preset's d_T, m; navbench.nav.presets)
PRESET_METRICS: tuple[tuple[str, str, str], ...] = (
    ("soft_spl", "soft_spl_term", "mean"),
    ("final_dist_m", "dist_to_goal_m", "mean"),
)
_STATS: dict[str, Callable] = {"mean": np.mean, "median": np.median}


def bootstrap_ci(values, stat: Callable | str = np.mean, n: int = N_BOOT, seed: int = 0,
                 level: float = CI_LEVEL) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``stat`` over ``values`` (1D; NaNs dropped).

    Draws ``n`` resamples of the values with replacement from ``np.random.default_rng(seed)``
    and returns the ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles of ``stat`` over them
    (the percentile method). ``stat`` must accept ``axis=1`` on a (n, m) array (``np.mean``,
    ``np.median``, or their names). No values: ``(nan, nan)``.
    """
    if isinstance(stat, str):
        stat = _STATS[stat]
    x = np.asarray(values, dtype=float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        return (float("nan"), float("nan"))
    if n < 1:
        raise ValueError("n must be >= 1")
    rng = np.random.default_rng(seed)
    stats = np.empty(n)
    rows = max(1, 4_000_000 // x.size)  # bound the (rows, m) resample block
    for start in range(0, n, rows):
        k = min(rows, n - start)
        idx = rng.integers(0, x.size, size=(k, x.size))
        stats[start:start + k] = stat(x[idx], axis=1)
    alpha = (1.0 - level) / 2.0
    low, high = np.quantile(stats, [alpha, 1.0 - alpha])
    return (float(low), float(high))


def _point(values, stat: str) -> float:
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return float(_STATS[stat](x)) if x.size else float("nan")


def _order_key(value: str, order: tuple[str, ...]) -> tuple[int, str]:
    return (order.index(value), "") if value in order else (len(order), str(value))


def estimator_variants(frame: "pandas.DataFrame") -> "pandas.Series":
    """Per-row label: the estimator name, or ``name{k=v,...}`` when the frame holds the same
    estimator with several option sets."""
    import pandas as pd

    if frame.empty:
        return pd.Series([], dtype=object, index=frame.index)
    opts = frame["estimator_options"].map(
        lambda o: json.dumps(o if isinstance(o, dict) else {}, sort_keys=True))
    counts = pd.DataFrame({"e": frame["estimator"], "o": opts}).groupby("e")["o"].nunique()
    labels = []
    for est, o in zip(frame["estimator"], opts):
        if counts.get(est, 1) > 1:
            d = json.loads(o)
            labels.append(est + "{" + ",".join(f"{k}={d[k]}" for k in sorted(d)) + "}")
        else:
            labels.append(est)
    return pd.Series(labels, index=frame.index, dtype=object)


def select_episodes(db: "ResultsDB", run: int | str | None = None,
                    level: str | list[str] | None = None,
                    cell_keys: "list[str] | set[str] | None" = None,
                    benchmark_version: str | None = None) -> "pandas.DataFrame":
    """The episodes that count (see the module docstring), optionally of one run, level(s) and
    cells (``cell_keys``: a run's grid); the selection comes before the once-per-(setup, task,
    seed) rule, so a run's own cells keep all their episodes. One benchmark version only: the
    newest present or ``benchmark_version`` (:func:`select_versioned` also says which)."""
    return select_versioned(db, run, level, cell_keys, benchmark_version)[0]


def select_versioned(db: "ResultsDB", run: int | str | None = None, level: str | list[str] | None = None,
                     cell_keys: "list[str] | set[str] | None" = None, benchmark_version: str | None = None
                     ) -> tuple["pandas.DataFrame", str | None, str | None]:
    """:func:`select_episodes` with the benchmark version it kept and a note naming the versions
    it left out (:func:`navbench.results.versions.choose_version`)."""
    from navbench.results.db.resume import resolve_run_ids
    from navbench.results.versions import choose_version

    run_ids = resolve_run_ids(db, run)
    levels = [level] if isinstance(level, str) else level
    frame = db.episodes_frame(run_ids=run_ids, level=levels or None)
    if cell_keys is not None and not frame.empty:
        frame = frame[frame["cell_key"].isin(set(cell_keys))]
    frame, version, note = choose_version(frame, benchmark_version)
    if not frame.empty:
        frame = (frame.sort_values("id")
                 .drop_duplicates(["cell_key", "task_id", "seed"], keep="last")
                 .reset_index(drop=True))
        frame = with_identities(frame, db.tasks_frame())
        frame = (frame.drop_duplicates(["setup", "task_uid", "seed"], keep="first")
                 .reset_index(drop=True))
        frame = with_conditions(frame, db.runs_frame())
    return frame, version, note


#: The ``conditions`` label of episodes whose run recorded no episode config.
UNRECORDED_CONDITIONS = "unrecorded"


def conditions_label(episode_overrides: "dict | None") -> str:
    """The simulator conditions (:mod:`navbench.sim.conditions`) an episode config selects, every
    one named: ``"pose_quantisation=off, direction_limit=believed, collision_check=swept"``
    (the defaults), and ``texture=...`` after them when the camera's texture mode is not
    ``procedural``. ``episode_overrides``: EpisodeConfig field overrides as a run records them
    (``config["episode"]``); ``None`` (not recorded) gives :data:`UNRECORDED_CONDITIONS`."""
    from navbench.sim.conditions import episode_conditions

    if not isinstance(episode_overrides, dict):
        return UNRECORDED_CONDITIONS
    label = ", ".join(f"{k}={v}" for k, v in episode_conditions(episode_overrides).items())
    # the camera's texture mode (navbench.sim.texels) is named only off its default, so the
    # labels of every run stored before it existed stay as they were
    texture = episode_overrides.get("texture", "procedural")
    return label if texture == "procedural" else f"{label}, texture={texture}"


def with_conditions(frame: "pandas.DataFrame", runs: "pandas.DataFrame") -> "pandas.DataFrame":
    """``frame`` (episodes) with a ``conditions`` column: :func:`conditions_label` of the episode
    config of the run that stored each episode (``runs``: :meth:`ResultsDB.runs_frame`). A run
    stores only its own grid's cells, so its config's episode settings are the episode's; the
    ``condition_key`` (a hash) also covers them but cannot be read back. Scoring groups and
    pairs by this label too, so episodes of different conditions never share a row."""
    configs = dict(zip(runs["id"], runs["config"])) if not runs.empty else {}
    from navbench.results.labels import online_label

    labels = {rid: conditions_label(cfg.get("episode") if isinstance(cfg, dict) else None) + online_label(cfg)
              for rid, cfg in configs.items()}
    return frame.assign(conditions=[labels.get(int(r), UNRECORDED_CONDITIONS) for r in frame["run_id"]])


def _conditions_of(frame: "pandas.DataFrame") -> "pandas.Series":
    """The ``conditions`` column, or :data:`UNRECORDED_CONDITIONS` for a frame without one."""
    if "conditions" in frame.columns:
        return frame["conditions"].fillna(UNRECORDED_CONDITIONS).astype(str)
    return frame["level"].map(lambda _: UNRECORDED_CONDITIONS).astype(object)


def _conditions_order(label: str) -> tuple[int, str]:
    """Sort key: the defaults first, unrecorded last, others by name."""
    return (0 if label == conditions_label({}) else 2 if label == UNRECORDED_CONDITIONS else 1, label)


def with_identities(frame: "pandas.DataFrame", tasks: "pandas.DataFrame | None" = None) -> "pandas.DataFrame":
    """``frame`` with the columns that say which episodes are the same experiment:

    * ``setup`` -- ``condition_key|estimator|options`` (level, map, noise, episode config and
      estimator: everything but the task set), or the ``cell_key`` for rows stored before
      ``condition_key`` existed;
    * ``task_uid`` -- the task itself: its id, start and target from the ``tasks`` table (so task
      3 of a 4-task set and of the 200-task set it is the prefix of are one task), else
      ``task_set_key:task_id``;
    * ``pair_condition`` -- the ``condition_key`` (else ``level|map_key|noise``): episodes of two
      estimators with equal ``(pair_condition, task_uid, seed)`` ran the same task with the same
      simulator noise stream.

    :func:`select_episodes` keeps one row per ``(setup, task_uid, seed)``: a larger ``--tasks``
    or ``--seeds`` after a smaller one extends the same setup and never counts an episode twice.
    """
    f = frame.copy()
    opts = f["estimator_options"].map(
        lambda o: json.dumps(o if isinstance(o, dict) else {}, sort_keys=True))
    cond = f["condition_key"] if "condition_key" in f.columns else f["cell_key"].map(lambda _: None)
    has = cond.notna()
    f["setup"] = f["cell_key"].astype(str)
    f.loc[has, "setup"] = cond[has].astype(str) + "|" + f.loc[has, "estimator"].astype(str) + "|" + opts[has]
    uid = {}
    if tasks is not None and not tasks.empty:
        for t in tasks.itertuples():
            uid[(t.task_set_key, int(t.task_id))] = (f"{int(t.task_id)}@{t.start_x!r},{t.start_y!r},"
                                                     f"{t.start_theta!r}->{t.target_x!r},{t.target_y!r}")
    f["task_uid"] = [uid.get((k, int(i)), f"{k}:{int(i)}") for k, i in zip(f["task_set_key"], f["task_id"])]
    legacy = f["level"].astype(str) + "|" + f["map_key"].astype(str) + "|" + f["noise"].astype(str)
    f["pair_condition"] = cond.where(has, legacy).astype(str)
    return f


#: Median per-step render + estimate time (ms) below which an estimator does no tracking work
#: (``dynamics``, ``gt``: no map render, no optimisation); its step time is the simulator's and
#: controller's alone, so no step rate is given for it (``step_hz`` NaN, ``tracking_work`` False).
NO_WORK_MS = 0.05


def tracks_per_step(cell: "pandas.DataFrame") -> bool:
    """Whether the episodes' median per-step render + estimate time reaches :data:`NO_WORK_MS`
    (True when the timings are not stored)."""
    cols = [c for c in ("render_ms", "estimate_ms") if c in cell.columns]
    if not cols:
        return True
    work = cell[cols].astype(float)
    if work.isna().all().all():
        return True
    return bool(np.median(work.fillna(0.0).sum(axis=1).to_numpy()) >= NO_WORK_MS)


def _strata(cell: "pandas.DataFrame", col: str) -> list[np.ndarray]:
    """The values of ``col`` split by level (the bootstrap's strata), levels in sorted order."""
    return [g[col].to_numpy(dtype=float) for _, g in cell.groupby("level", sort=True)]


def summarise(frame: "pandas.DataFrame", n_boot: int = N_BOOT, seed: int = 0,
              pooled: bool = True, preset: str | None = None) -> "pandas.DataFrame":
    """Per (level, estimator, noise, goal) metrics with bootstrap intervals from an episodes frame.

    ``pooled`` adds ``level = "all"`` rows over every level. Columns: level, estimator, noise,
    episodes, then for each metric ``m``: ``m``, ``m_ci_low``, ``m_ci_high``; and ``step_hz``
    with its interval. ``conditions``: the simulator conditions of the row's episodes
    (:func:`with_conditions`; a frame without the column is :data:`UNRECORDED_CONDITIONS`): rows
    are per (level, estimator, noise, conditions, goal), so episodes run under different
    conditions never pool into one row. Then (issue 15) ``goal``, ``preset`` and the
    :data:`PRESET_METRICS` with their intervals. Success and SPL follow the scoring ``preset``
    (:func:`navbench.results.presets.apply_preset`; default the frame's own, else
    ``paper``: the stored values). Rows sorted by level ("all" last), conditions (the defaults
    first), noise, goal, estimator.
    """
    import pandas as pd

    from navbench.results.presets import GOAL_ORDER, apply_preset

    columns = ["level", "estimator", "noise", "episodes", "setups"]
    for name, _, _ in METRICS:
        columns += [name, f"{name}_ci_low", f"{name}_ci_high"]
    columns += ["step_hz", "step_hz_ci_low", "step_hz_ci_high", "tracking_work", "conditions", "goal", "preset"]
    for name, _, _ in PRESET_METRICS:
        columns += [name, f"{name}_ci_low", f"{name}_ci_high"]
    if "soft_spl_term" not in frame.columns or (preset and preset != frame.attrs.get("preset")):
        frame = apply_preset(frame, preset or "paper")
    if frame.empty:
        return pd.DataFrame(columns=columns)
    f = frame.copy()
    f["variant"] = estimator_variants(f)
    f["success"] = f["success"].astype(float)
    f["conditions"] = _conditions_of(f)
    groups = [(lvl, g) for lvl, g in f.groupby("level", sort=True)]
    if pooled:
        groups.append(("all", f))
    out = []
    for lvl, g in groups:
        for (est, noise, conds, goal), cell in g.groupby(["variant", "noise", "conditions", "goal"], sort=False):
            setup_col = "setup" if "setup" in cell.columns else "cell_key"
            setups = int(cell.groupby("level")[setup_col].nunique().max())
            row: dict[str, Any] = {"level": lvl, "estimator": est, "noise": noise, "conditions": conds,
                                   "episodes": int(len(cell)), "setups": setups, "goal": goal,
                                   "preset": f.attrs.get("preset", "paper")}
            for name, col, stat in METRICS + PRESET_METRICS:
                vals = cell[col].to_numpy(dtype=float)
                row[name] = _point(vals, stat)
                if name == "success_rate":
                    ok = vals[np.isfinite(vals)]
                    ci = clopper_pearson(int(ok.sum()), ok.size, CI_LEVEL)
                elif name in ("spl", "soft_spl"):
                    ci = stratified_bootstrap_ci(_strata(cell, col), CI_LEVEL, n_boot, seed)
                else:
                    ci = bootstrap_ci(vals, stat, n_boot, seed)
                row[f"{name}_ci_low"], row[f"{name}_ci_high"] = ci
            with np.errstate(divide="ignore"):
                row["step_hz"] = 1000.0 / row["step_ms"] if row["step_ms"] > 0 else float("nan")
                hi, lo = row["step_ms_ci_low"], row["step_ms_ci_high"]
                row["step_hz_ci_low"] = 1000.0 / lo if lo > 0 else float("nan")
                row["step_hz_ci_high"] = 1000.0 / hi if hi > 0 else float("nan")
            row["tracking_work"] = tracks_per_step(cell)
            if not row["tracking_work"]:  # a step of dynamics/gt is no tracking rate
                row["step_hz"] = row["step_hz_ci_low"] = row["step_hz_ci_high"] = float("nan")
            out.append(row)
    table = pd.DataFrame(out, columns=columns)
    key = table.apply(lambda r: (r["level"] == "all", r["level"], _conditions_order(r["conditions"]),
                                 _order_key(r["noise"], NOISE_ORDER), _order_key(r["goal"], GOAL_ORDER),
                                 _order_key(r["estimator"].split("{")[0], ESTIMATOR_ORDER),
                                 r["estimator"]), axis=1)
    return table.iloc[sorted(range(len(table)), key=lambda i: key.iloc[i])].reset_index(drop=True)


def mixed_setups(table: "pandas.DataFrame") -> list[str]:
    """``"level/estimator/noise"`` of every per-level row of a score table that pools episodes
    of more than one setup (cell): a warning's worth, see the module docstring."""
    if table.empty or "setups" not in table.columns:
        return []
    rows = table[(table["level"] != "all") & (table["setups"] > 1)]
    return [f"{r.level}/{r.estimator}/{r.noise}" for r in rows.itertuples()]


def mixed_setups_warning(table: "pandas.DataFrame") -> str | None:
    """One line naming the rows of :func:`mixed_setups`, or ``None``."""
    mixed = mixed_setups(table)
    if not mixed:
        return None
    shown = ", ".join(mixed[:4]) + (f" and {len(mixed) - 4} more" if len(mixed) > 4 else "")
    return (f"{len(mixed)} row(s) pool episodes of several setups (maps, task sets or episode "
            f"settings): {shown}; narrow with --run, or keep experiments in separate databases")


def score_table(db: "ResultsDB", run: int | str | None = None, level: str | list[str] | None = None,
                n_boot: int = N_BOOT, seed: int = 0, preset: str = "paper",
                benchmark_version: str | None = None) -> "pandas.DataFrame":
    """Score the stored episodes: :func:`select_episodes` then :func:`summarise` under the
    scoring ``preset``. Raises :class:`DatabaseError` when no episode matches.
    """
    from navbench.results.presets import apply_preset

    return summarise(apply_preset(_selected(db, run, level, benchmark_version), preset), n_boot=n_boot, seed=seed)


def score_tables(db: "ResultsDB", run: int | str | None = None, level: str | list[str] | None = None,
                 n_boot: int = N_BOOT, seed: int = 0, preset: str = "paper",
                 benchmark_version: str | None = None) -> tuple["pandas.DataFrame", "pandas.DataFrame"]:
    """``(score table, paired differences)`` of the stored episodes: :func:`score_table` and
    :func:`paired_differences` of the same selection, both under the scoring ``preset``.
    Raises :class:`DatabaseError` when no episode matches."""
    from navbench.results.presets import apply_preset

    frame = apply_preset(_selected(db, run, level, benchmark_version), preset)
    return (summarise(frame, n_boot=n_boot, seed=seed),
            paired_differences(frame, n_boot=n_boot, seed=seed))


def _selected(db: "ResultsDB", run, level, benchmark_version: str | None = None) -> "pandas.DataFrame":
    frame = select_episodes(db, run=run, level=level, benchmark_version=benchmark_version)
    if frame.empty:
        what = [f"run {run}" if run not in (None, "all") else "", f"level {level}" if level else ""]
        detail = " for " + " and ".join(w for w in what if w) if any(what) else ""
        raise DatabaseError(f"no episodes{detail} in {db.display_url}; run `navbench run-navigation` first")
    return frame


def spl_matrix(table: "pandas.DataFrame", level: str = "all", digits: int = 2,
               conditions: str | None = None) -> "pandas.DataFrame":
    """The paper's Fig. 5a layout: rows noise (high, mid, low...), columns estimators, cells
    ``"0.92 [0.89, 0.95]"`` (SPL with its 95 % interval) for one ``level`` of a score table and,
    when given, one ``conditions`` label (a table of several conditions needs one matrix each:
    :func:`conditions_in`)."""
    import pandas as pd

    t = table[table["level"] == level]
    if conditions is not None and "conditions" in t.columns:
        t = t[t["conditions"] == conditions]
    if "goal" in t.columns and (t["goal"] == "point").any():  # Fig. 5a is the point-goal figure
        t = t[t["goal"] == "point"]
    noises = sorted(t["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER), reverse=True)
    ests = sorted(t["estimator"].unique(),
                  key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
    cells = {}
    for _, r in t.iterrows():
        cells[(r["noise"], r["estimator"])] = (
            f"{r['spl']:.{digits}f} [{r['spl_ci_low']:.{digits}f}, {r['spl_ci_high']:.{digits}f}]")
    data = [[cells.get((n, e), "") for e in ests] for n in noises]
    return pd.DataFrame(data, index=pd.Index(noises, name="noise"), columns=ests)


def conditions_in(table: "pandas.DataFrame") -> list[str]:
    """The distinct ``conditions`` labels of a score or paired table, the defaults first."""
    if table is None or table.empty or "conditions" not in table.columns:
        return []
    return sorted(set(table["conditions"].astype(str)), key=_conditions_order)


def short_conditions(label: str) -> str:
    """A :func:`conditions_label` with the conditions at their defaults left out
    (``"direction_limit=true"``; ``"defaults"`` when none differs): a narrow table column."""
    from navbench.sim.conditions import CONDITIONS

    if label == UNRECORDED_CONDITIONS:
        return label
    parts = [p for p in str(label).split(", ")
             if p.partition("=")[0] not in CONDITIONS or p.partition("=")[2] != CONDITIONS[p.partition("=")[0]].default]
    return ", ".join(parts) or "defaults"


def table_records(table: "pandas.DataFrame") -> list[dict]:
    """JSON-ready records (NaN -> None, numpy scalars -> Python)."""
    records = []
    for rec in table.to_dict(orient="records"):
        clean = {}
        for k, v in rec.items():
            if isinstance(v, np.generic):
                v = v.item()
            if isinstance(v, float) and not np.isfinite(v):
                v = None
            clean[k] = v
        records.append(clean)
    return records


#: The paper's claim (Fig. 5a): ``ours`` against each ablation.
CLAIM_REFERENCE = "ours"
CLAIM_OTHERS = ("no-map", "dynamics")
PAIRED_COLUMNS = ["level", "noise", "comparison", "reference", "other", "pairs", "unpaired_reference",
                  "unpaired_other", "reference_spl", "other_spl", "spl_diff", "spl_diff_ci_low",
                  "spl_diff_ci_high", "success_diff", "success_diff_ci_low", "success_diff_ci_high",
                  "conditions"]


def paired_differences(frame: "pandas.DataFrame", reference: str = CLAIM_REFERENCE,
                       others: tuple[str, ...] = CLAIM_OTHERS, n_boot: int = N_BOOT, seed: int = 0,
                       pooled: bool = True) -> "pandas.DataFrame":
    """``reference - other`` SPL and success on the same episodes, per (level, noise) and pooled.

    ``frame``: episodes as :func:`select_episodes` returns them. A pair is the reference's and
    the other estimator's episode with equal ``(pair_condition, task_uid, seed)``
    (:func:`with_identities`): same level, map, noise, episode config, task and simulator noise
    stream. ``spl_diff`` is the mean over pairs of ``spl_ref - spl_other`` (so it equals the
    difference of the two SPLs over the paired episodes, ``reference_spl - other_spl``), with a
    BCa bootstrap interval that resamples pairs within each level
    (:func:`~navbench.nav.metrics.stratified_bootstrap_ci`); ``success_diff`` likewise with the
    success flags. Episodes without a partner are left out and counted (``unpaired_reference``,
    ``unpaired_other``). Rows are per ``conditions`` too (:func:`with_conditions`), and only
    episodes of equal conditions pair. ``reference`` and ``others`` are estimator names; each variant
    (``name{options}``) of them is compared. Rows: levels sorted, then ``"all"``; noise in
    :data:`NOISE_ORDER`; one row per comparison present (columns :data:`PAIRED_COLUMNS`).
    """
    import pandas as pd

    from navbench.results.paired import paired_table

    if frame.empty:
        return pd.DataFrame(columns=PAIRED_COLUMNS)
    f = frame if "pair_condition" in frame.columns else with_identities(frame)
    f = f.assign(variant=estimator_variants(f), success=f["success"].astype(float),
                 conditions=_conditions_of(f))
    base = f["variant"].map(lambda v: v.split("{")[0])
    refs = sorted(f.loc[base == reference, "variant"].unique())
    oths = sorted(f.loc[base.isin(others), "variant"].unique(),
                  key=lambda v: (_order_key(v.split("{")[0], ESTIMATOR_ORDER), v))
    keys = ["pair_condition", "conditions", "task_uid", "seed"]
    f = f.drop_duplicates(["variant"] + keys)
    # navbench.results.paired: B - A, so the other estimator is side A and the reference side B
    t = paired_table(f, f, [(oth, ref) for ref in refs for oth in oths], keys, method="bca",
                     n_boot=n_boot, seed=seed, pooled=pooled, metrics=("spl", "success"))
    t = t.rename(columns={"estimator_b": "reference", "estimator_a": "other", "unpaired_b": "unpaired_reference",
                          "unpaired_a": "unpaired_other", "spl_b": "reference_spl", "spl_a": "other_spl"})
    t["comparison"] = t["reference"] + " - " + t["other"]
    table = t[PAIRED_COLUMNS]
    if table.empty:
        return table
    key = [((r.level == "all"), r.level, _conditions_order(r.conditions), _order_key(r.noise, NOISE_ORDER),
            r.reference,
            _order_key(r.other.split("{")[0], ESTIMATOR_ORDER), r.other) for r in table.itertuples()]
    order = sorted(range(len(table)), key=lambda i: key[i])
    return table.iloc[order].reset_index(drop=True)


def difficulty_table(frame: "pandas.DataFrame", preset: str = "paper") -> "pandas.DataFrame":
    """Success rate (with its exact 95 % interval), SPL, SoftSPL and mean final distance per
    (level, estimator variant, noise, conditions, goal, difficulty), with pooled ``level = "all"``
    and ``difficulty = "all"`` rows; columns ``preset``, ``level``, ``estimator``, ``noise``,
    ``goal``, ``difficulty``, ``episodes``, ``success_rate``, ``success_rate_ci_low``,
    ``success_rate_ci_high``, ``spl``, ``soft_spl``, ``final_dist_m``, ``conditions`` (as in
    :func:`summarise`: episodes of other conditions or map modes never pool)."""
    import pandas as pd

    from navbench.results.presets import DIFFICULTY_ORDER, GOAL_ORDER, apply_preset

    cols = ["preset", "level", "estimator", "noise", "goal", "difficulty", "episodes", "success_rate",
            "success_rate_ci_low", "success_rate_ci_high", "spl", "soft_spl", "final_dist_m", "conditions"]
    f = frame if "soft_spl_term" in frame.columns else apply_preset(frame, preset)
    name = f.attrs.get("preset", preset)
    if f.empty:
        return pd.DataFrame(columns=cols)
    f = f.assign(variant=estimator_variants(f), success=f["success"].astype(float), conditions=_conditions_of(f))
    out = []
    levels = [(lvl, g) for lvl, g in f.groupby("level", sort=True)] + [("all", f)]
    for lvl, g in levels:
        for (est, noise, conds, goal), cell in g.groupby(["variant", "noise", "conditions", "goal"], sort=False):
            parts = [(d, c) for d, c in cell.groupby("difficulty", sort=False)] + [("all", cell)]
            for diff, c in parts:
                ok = c["success"].to_numpy(dtype=float)
                lo, hi = clopper_pearson(int(ok.sum()), ok.size, 0.95)
                out.append({"preset": name, "level": lvl, "estimator": est, "noise": noise, "goal": goal,
                            "difficulty": diff, "episodes": int(len(c)), "success_rate": float(ok.mean()),
                            "success_rate_ci_low": lo, "success_rate_ci_high": hi,
                            "spl": float(c["spl_term"].astype(float).mean()),
                            "soft_spl": _finite_mean(c["soft_spl_term"]), "final_dist_m": _finite_mean(c["dist_to_goal_m"]),
                            "conditions": conds})
    table = pd.DataFrame(out, columns=cols)
    key = [(r.level == "all", r.level, _order_key(r.noise, NOISE_ORDER), _conditions_order(r.conditions),
            _order_key(r.goal, GOAL_ORDER),
            _order_key(r.estimator.split("{")[0], ESTIMATOR_ORDER), r.estimator,
            _order_key(r.difficulty, DIFFICULTY_ORDER)) for r in table.itertuples()]
    return table.iloc[sorted(range(len(table)), key=lambda i: key[i])].reset_index(drop=True)


def _finite_mean(values) -> float:
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else float("nan")
