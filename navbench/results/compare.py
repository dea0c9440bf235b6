"""``navbench compare``: paired differences between any two sides on the same episodes (issue 35).

A side is a selection of stored episodes and an estimator of it. Two ways to name them:

* **two estimators of one selection** (``pairs=[("ours-every-k", "ours")]``; optionally narrowed
  to runs ``a``): episodes pair when they ran the same level, map, noise, simulator conditions,
  task and seed (``score``'s rule for its claim rows, :func:`navbench.results.score.with_identities`);
* **two selections**: runs ``a`` and runs ``b`` of one database, or of two (``b_db``): episodes
  pair on the same level, noise, task (its start and goal) and seed, estimator by estimator (or
  as ``pairs`` maps them). What differs between the sides (map budget, ablation, code version)
  is what is compared; the conditions column names both sides' conditions where they differ.
  Within a side, a (level, noise, task, seed, estimator) stored under several setups keeps its
  last stored row (a warning counts them).

Every difference is **B - A** (the second side minus the first, as ``--a old --b new``); the
statistics and intervals are :mod:`navbench.results.paired`'s. Both sides are scored under one
preset (:func:`navbench.results.presets.apply_preset`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from navbench.errors import ConfigError, DatabaseError

if TYPE_CHECKING:  # pragma: no cover
    import pandas

#: Join keys of two selections (:func:`compare` with ``b`` or ``b_db``).
SIDE_KEYS = ["level", "noise", "task_uid", "seed"]
#: Join keys of two estimators of one selection (score's claim rows).
ESTIMATOR_KEYS = ["pair_condition", "conditions", "task_uid", "seed"]


@dataclass
class Comparison:
    """What :func:`compare` returns: the table (:data:`navbench.results.paired.COLUMNS` plus
    ``preset``), the preset, the interval method in words, both sides in words, warnings."""

    table: "pandas.DataFrame"
    preset: str
    interval: str
    side_a: str
    side_b: str
    warnings: list[str] = field(default_factory=list)


def parse_pair(text: str, where: str = "--pair") -> tuple[str, str]:
    """``"A:B"`` -> ``("A", "B")``; :class:`ConfigError` for anything else."""
    a, sep, b = str(text).partition(":")
    if not sep or not a.strip() or not b.strip() or ":" in b:
        raise ConfigError(f"{where}: give two estimators as A:B (for example ours-every-k:ours), not {text!r}")
    return a.strip(), b.strip()


def _variants_named(name: str, variants: list[str]) -> list[str]:
    """The variant labels ``name`` means: itself, else every ``name{options}`` variant."""
    if name in variants:
        return [name]
    return [v for v in variants if v.split("{")[0] == name]


def resolve_pairs(pairs, variants_a: list[str], variants_b: list[str], side_a: str = "A",
                  side_b: str = "B", strict: bool = True, same: bool = False) -> list[tuple[str, str]]:
    """Every (variant of A, variant of B) the named ``pairs`` mean; a name its side does not hold
    is a :class:`ConfigError` naming what the side holds (``strict``) or skipped. ``same``: both
    sides are one selection, so an estimator is never paired with itself."""
    out: list[tuple[str, str]] = []
    for a, b in pairs:
        found = []
        for name, variants, side in ((a, variants_a, side_a), (b, variants_b, side_b)):
            got = _variants_named(name, variants)
            if not got and strict:
                held = ", ".join(variants) or "no episodes"
                raise ConfigError(f"--pair: no estimator {name!r} in {side}; it holds: {held}")
            found.append(got)
        if same and strict and a == b:
            raise ConfigError(f"--pair {a}:{b} compares an estimator with itself; name two estimators, "
                              "or two sides with --a/--b or --b-db")
        out += [(x, y) for x in found[0] for y in found[1] if (x, y) not in out and (x != y or not same)]
    return out


def _side(db, runs, level, where: str, version: str | None = None,
          warnings: list | None = None) -> "tuple[pandas.DataFrame, str, str | None]":
    """One side's episodes, of one benchmark version (``version``, else the newest of the side;
    a note naming what was left out goes to ``warnings``), the side in words, and that version
    (``None``: the side holds no episode)."""
    from navbench.results.db.resume import resolve_run_ids
    from navbench.results.score import select_versioned

    try:
        ids = resolve_run_ids(db, runs)
    except DatabaseError as e:  # it names --run: say which option it was
        raise type(e)(str(e).replace("--run", where)) from None
    frame, chosen, note = select_versioned(db, run=None if ids is None else ",".join(map(str, ids)),
                                           level=level, benchmark_version=version)
    if note and warnings is not None:
        warnings.append(f"side {where[2:].upper()}: {note}")
    what = "all episodes" if ids is None else f"run{'s' if len(ids) > 1 else ''} {','.join(map(str, ids))}"
    return frame, f"{what} of {db.display_url}" + (f", {chosen}" if chosen else ""), chosen


def compare(db: str | None = None, pairs=(), a: str | None = None, b: str | None = None,
            b_db: str | None = None, preset: str | None = None, level: list[str] | None = None,
            method: str = "bca", n_boot: int | None = None, seed: int = 0,
            benchmark_version: str | None = None) -> Comparison:
    """Paired differences B - A (module docstring). ``db``: the database of side A (and of B
    unless ``b_db``; ``None``: ``NAVBENCH_DB`` or the project's default); ``pairs``: ``(A, B)``
    estimator names (``"A:B"`` strings are parsed); ``a``, ``b``: run selections (``"35,54"``,
    ``"latest"``, ``"all"``); ``preset``: scoring preset (default ``paper``, ``nrns`` when every
    episode is an unknown-house one); ``level``: only these levels; ``method``: ``"bca"`` or
    ``"percentile"`` (:mod:`navbench.results.paired`), ``n_boot`` resamples (its default);
    ``benchmark_version``: read that version on both sides (default: each side's newest; the
    side names its version, and a warning says when the two sides' versions differ).
    Bad input (an unknown run, estimator or preset, no episodes) raises a
    :class:`~navbench.errors.NavbenchError`.
    """
    import pandas as pd

    from navbench.nav.presets import get_preset
    from navbench.results.db import ResultsDB
    from navbench.results.presets import default_preset, missing_distances
    from navbench.results.paired import DEFAULT_BOOT, METHODS, method_label

    if method not in METHODS:
        raise ConfigError(f"--interval: unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if preset is not None:
        get_preset(preset, "--preset")
    pairs = [parse_pair(p) if isinstance(p, str) else tuple(p) for p in pairs]
    two_sides = b is not None or b_db is not None
    if not two_sides and not pairs:
        raise ConfigError("name what to compare: two estimators (--pair A:B) or two sides "
                          "(--a RUNS --b RUNS, or --b-db URL)")
    warnings: list[str] = []
    with ResultsDB(db, create=False) as rdb:
        fa, side_a, version_a = _side(rdb, a, level, "--a", benchmark_version, warnings)
        if b_db is not None:
            try:
                rdb_b = ResultsDB(b_db, create=False)
            except DatabaseError as e:  # it suggests --db: the option here is --b-db
                raise DatabaseError(f"--b-db: {str(e).split('; run `navbench all`')[0]}") from None
            with rdb_b:
                fb, side_b, version_b = _side(rdb_b, b, level, "--b", benchmark_version, warnings)
        elif two_sides:
            fb, side_b, version_b = _side(rdb, b, level, "--b", benchmark_version, warnings)
        else:
            fb, side_b, version_b = fa, side_a, version_a
    if two_sides and version_a and version_b and version_a != version_b:
        warnings.append(f"side A is {version_a} and side B {version_b}: a "
                        "comparison across benchmark versions (what a version's acceptance test measures)")
    for frame, side in ((fa, side_a), (fb, side_b)):
        if frame.empty:
            raise ConfigError(f"no episodes in {side}" + (f" at level {', '.join(level)}" if level else ""))
    if preset is None:
        preset, mixed = default_preset(pd.concat([fa, fb], ignore_index=True))
        if mixed:
            warnings.append(mixed)
    missing = missing_distances(fa) + (missing_distances(fb) if two_sides else 0)
    if missing and preset != "paper":
        warnings.append(f"{missing} episode(s) were stored without their final distance (before scoring "
                        f"presets); under preset {preset!r} they count as failures")

    if not two_sides:
        table = estimator_pairs(_prepared(fa, preset), pairs, method=method, n_boot=n_boot, seed=seed,
                                where=side_a)
    else:
        table = side_pairs(fa, fb, preset, pairs, method=method, n_boot=n_boot, seed=seed, side_a=side_a,
                           side_b=side_b, warnings=warnings)
    for (pa, pb), rows in table[table["level"] == "all"].groupby(["estimator_a", "estimator_b"], sort=False):
        if int(rows["pairs"].sum()) == 0:
            warnings.append(f"{pb} - {pa}: no episode pairs (no common level, noise, task and seed)")
    n = DEFAULT_BOOT[method] if n_boot is None else int(n_boot)
    return Comparison(table=table, preset=preset, interval=method_label(method, n, seed),
                      side_a=side_a, side_b=side_b, warnings=warnings)


def side_pairs(fa: "pandas.DataFrame", fb: "pandas.DataFrame", preset: str, pairs=(), method: str = "bca",
               n_boot: int | None = None, seed: int = 0, side_a: str = "A", side_b: str = "B",
               warnings: list | None = None) -> "pandas.DataFrame":
    """B - A of two selections (:func:`compare` with ``b`` or ``b_db``; frames in, frame out):
    ``fa``, ``fb`` episodes of one benchmark version each
    (:func:`navbench.results.score.select_versioned`), scored under ``preset``; episodes pair on
    :data:`SIDE_KEYS`, estimator by estimator (every estimator both sides hold, or as ``pairs``
    maps them). ``side_a``, ``side_b``: the sides in words (error messages); ``warnings``: a
    list the duplicate counts are appended to. Returns :func:`compare`'s table; sides sharing no
    estimator are a :class:`ConfigError`."""
    from navbench.results.paired import paired_table

    fa, fb = _prepared(fa, preset), _prepared(fb, preset)
    va, vb = _variants(fa), _variants(fb)
    keys = SIDE_KEYS
    pairs = [parse_pair(p) if isinstance(p, str) else tuple(p) for p in pairs]
    if not pairs:
        pairs = [(v, v) for v in va if v in vb]
        if not pairs:
            raise ConfigError(f"the sides share no estimator (A: {', '.join(va)}; B: {', '.join(vb)}); "
                              "pair two with --pair A:B")
    for name, f in (("A", fa), ("B", fb)):
        dup = int(f.duplicated(["variant"] + keys).sum())
        if dup and warnings is not None:
            warnings.append(f"side {name}: {dup} episode(s) share (level, noise, task, seed, estimator) "
                            "with another setup of the same side; the last stored kept")
    fa = fa.sort_values("id").drop_duplicates(["variant"] + keys, keep="last")
    fb = fb.sort_values("id").drop_duplicates(["variant"] + keys, keep="last")
    resolved = resolve_pairs(pairs, va, vb, f"side A ({side_a})", f"side B ({side_b})")
    table = paired_table(fa, fb, resolved, keys, by_conditions=False, method=method, n_boot=n_boot, seed=seed)
    # the same estimator on both sides: say which side each is
    table["comparison"] = [f"{y} (B) - {x} (A)" for x, y in zip(table["estimator_a"], table["estimator_b"])]
    return _sorted(table, resolved, preset)


def _prepared(frame: "pandas.DataFrame", preset: str) -> "pandas.DataFrame":
    """Episodes scored under ``preset`` with the columns :func:`paired_table` reads."""
    from navbench.results.score import _conditions_of, estimator_variants, with_identities
    from navbench.results.presets import apply_preset

    f = frame if frame.attrs.get("preset") == preset else apply_preset(frame, preset)
    if "pair_condition" not in f.columns:
        f = with_identities(f)
    return f.assign(variant=estimator_variants(f), success=f["success"].astype(float), conditions=_conditions_of(f))


def _variants(frame: "pandas.DataFrame") -> list[str]:
    from navbench.results.score import ESTIMATOR_ORDER, _order_key

    return sorted(frame["variant"].unique(), key=lambda v: (_order_key(v.split("{")[0], ESTIMATOR_ORDER), v))


def _sorted(table: "pandas.DataFrame", resolved: list, preset: str) -> "pandas.DataFrame":
    """Rows by pair (as named), level (pooled last), conditions (defaults first), noise; a
    ``preset`` column first."""
    from navbench.results.score import NOISE_ORDER, _conditions_order, _order_key

    rank = {p: i for i, p in enumerate(resolved)}
    key = [(rank[(r.estimator_a, r.estimator_b)], r.level == "all", r.level, _conditions_order(r.conditions),
            _order_key(r.noise, NOISE_ORDER)) for r in table.itertuples()]
    table = table.iloc[sorted(range(len(table)), key=lambda i: key[i])].reset_index(drop=True)
    table.insert(0, "preset", preset)
    return table


def estimator_pairs(episodes: "pandas.DataFrame", pairs, method: str = "bca", n_boot: int | None = None,
                    seed: int = 0, where: str = "the selection") -> "pandas.DataFrame":
    """B - A for the named estimator ``pairs`` (``(A, B)`` or ``"A:B"``) of one episodes frame
    (:func:`navbench.results.score.select_episodes`, scored under a preset or, unscored,
    under ``paper``): episodes pair on the same level, map, noise, conditions, task and seed.
    An estimator the frame does not hold is a :class:`ConfigError` naming ``where``."""
    from navbench.results.paired import paired_table

    preset = episodes.attrs.get("preset") or "paper"
    f = _prepared(episodes, preset)
    pairs = [parse_pair(p) if isinstance(p, str) else tuple(p) for p in pairs]
    variants = _variants(f)
    resolved = resolve_pairs(pairs, variants, variants, where, where, same=True)
    f = f.drop_duplicates(["variant"] + ESTIMATOR_KEYS)
    table = paired_table(f, f, resolved, ESTIMATOR_KEYS, by_conditions=True, method=method, n_boot=n_boot, seed=seed)
    return _sorted(table, resolved, preset)


# --- formatting (CLI and report) ---------------------------------------------------------------

def fmt_diff(value, low, high, digits: int = 3) -> str:
    """``"+0.081 [+0.075, +0.088]"``; ``"-"`` for NaN."""
    if value != value:
        return "-"
    return f"{value:+.{digits}f} [{low:+.{digits}f}, {high:+.{digits}f}]"


def fmt_p(p) -> str:
    """An exact p-value: two decimals from 0.1 up, else two significant figures, ``"<0.001"``
    below 0.001."""
    if p != p:
        return "-"
    return "<0.001" if p < 0.001 else f"{p:.2f}" if p >= 0.1 else f"{p:.2g}"


def _fmt(v, digits: int = 3) -> str:
    return "-" if v != v else f"{v:.{digits}f}"


def short_label(label: str) -> str:
    """A conditions label with the conditions at their defaults left out
    (:func:`navbench.results.score.short_conditions`), also inside ``"A: ...; B: ..."`` and
    ``" | "``-joined labels of two selections."""
    import re

    from navbench.results.score import short_conditions

    parts = re.split(r"(^A: |; B: | \| )", str(label))
    return "".join(p if p in ("A: ", "; B: ", " | ") or not p else short_conditions(p) for p in parts)


#: The column groups of :func:`display_rows`: success, then the path and tracking metrics.
PARTS = ("success", "path")


def display_rows(table: "pandas.DataFrame", conditions: bool = False, part: str | None = None,
                 repeat_pooled: bool = True) -> tuple[list[str], list[list[str]]]:
    """Headers and string cells of a :func:`compare` table: one row per (comparison, level,
    noise[, conditions]); differences B - A with their interval. ``part``: only the success
    columns (``"success"``) or only SPL, SoftSPL and RMSE (``"path"``); ``None``: all.
    ``repeat_pooled=False`` leaves out a comparison's pooled rows when it covers one level (they
    repeat that level's rows)."""
    t = table
    if not repeat_pooled and not t.empty:
        levels = t[t["level"] != "all"].groupby("comparison")["level"].nunique()
        t = t[(t["level"] != "all") | t["comparison"].map(lambda c: levels.get(c, 0) != 1)]
    key = ["B - A", "level", "noise"] + (["conditions"] if conditions else [])
    succ = ["pairs (unpaired A / B)", "SR A / B", "SR B - A [95 %]", "only A / B (McNemar p)"]
    path = ["SPL A / B", "SPL B - A [95 %]", "SoftSPL B - A [95 %]", "loc RMSE m B - A [95 %]"]
    head = key + (succ if part in (None, "success") else []) + (path if part in (None, "path") else [])
    rows = []
    for r in t.itertuples():
        cells = [str(r.comparison), str(r.level), str(r.noise)] + ([short_label(r.conditions)] if conditions else [])
        if part in (None, "success"):
            cells += [f"{r.pairs} ({r.unpaired_a} / {r.unpaired_b})",
                      f"{_fmt(r.success_a)} / {_fmt(r.success_b)}",
                      fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high),
                      f"{r.only_a} / {r.only_b} (p {fmt_p(r.mcnemar_p)})"]
        if part in (None, "path"):
            cells += [f"{_fmt(r.spl_a)} / {_fmt(r.spl_b)}",
                      fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high),
                      fmt_diff(r.soft_spl_diff, r.soft_spl_diff_ci_low, r.soft_spl_diff_ci_high),
                      fmt_diff(r.loc_rmse_diff, r.loc_rmse_diff_ci_low, r.loc_rmse_diff_ci_high)]
        rows.append(cells)
    return head, rows


def record_rows(table: "pandas.DataFrame", conditions: bool = False) -> list[tuple[str, list[list[str]]]]:
    """The comparison as one block per comparison (and, with ``conditions``, per conditions
    label, named in the block's title), six rows per (level, noise): pairs (unpaired A / B), SR,
    its discordant counts and McNemar's p, SPL, SoftSPL and location RMSE with A, B and B - A
    [95 %]: a layout that fits 80 columns. A block's pooled rows are left out when it covers one
    level (they repeat it); a row of no pairs shows its counts alone. Returns ``[(title, rows)]``,
    rows of ``[level, noise, what, A, B, B - A]``."""
    blocks: list[tuple[str, list[list[str]]]] = []
    if table.empty:
        return blocks
    keys = ["comparison", "conditions"] if conditions else ["comparison"]
    for key, t in table.groupby(keys, sort=False):
        key = key if isinstance(key, tuple) else (key,)
        title = str(key[0]) + (f"; conditions: {short_label(key[1])}" if conditions else "")
        if t.loc[t["level"] != "all", "level"].nunique() == 1:
            t = t[t["level"] != "all"]
        rows = []
        for r in t.itertuples():
            where = [str(r.level), str(r.noise)]
            if not r.pairs:  # nothing to compare: the counts alone
                rows.append(where + ["pairs (unpaired A/B)", "", "", f"0 ({r.unpaired_a} / {r.unpaired_b})"])
                continue

            def n(k):
                return "" if k == r.pairs else f" ({k} pairs)"
            rows += [where + ["pairs (unpaired A/B)", "", "", f"{r.pairs} ({r.unpaired_a} / {r.unpaired_b})"],
                     ["", "", "SR", _fmt(r.success_a), _fmt(r.success_b),
                      fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high)],
                     ["", "", "  only A / only B", "", "",
                      f"{r.only_a} / {r.only_b}, McNemar p {fmt_p(r.mcnemar_p)}"],
                     ["", "", "SPL", _fmt(r.spl_a), _fmt(r.spl_b),
                      fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)],
                     ["", "", "SoftSPL" + n(r.soft_spl_pairs), _fmt(r.soft_spl_a), _fmt(r.soft_spl_b),
                      fmt_diff(r.soft_spl_diff, r.soft_spl_diff_ci_low, r.soft_spl_diff_ci_high)],
                     ["", "", "loc RMSE m" + n(r.loc_rmse_pairs), _fmt(r.loc_rmse_a), _fmt(r.loc_rmse_b),
                      fmt_diff(r.loc_rmse_diff, r.loc_rmse_diff_ci_low, r.loc_rmse_diff_ci_high)]]
        blocks.append((title, rows))
    return blocks


def markdown(table: "pandas.DataFrame") -> str:
    """The comparison as one GitHub-flavoured markdown table (``|`` in names escaped)."""
    several = table["conditions"].nunique() > 1 if not table.empty else False
    head, rows = display_rows(table, conditions=several, repeat_pooled=False)
    esc = lambda s: s.replace("|", "\\|")  # noqa: E731
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(esc(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"
