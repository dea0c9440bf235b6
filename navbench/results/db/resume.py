"""Which runs a ``--run`` selection means, and which runs make up one resumed measurement.

A run that is interrupted (Ctrl-C, a killed process, a lost machine) or fails keeps the episodes
it stored; rerunning the same command skips them and stores the rest under a new run id, which
owns only what it added. The runs of one measurement are therefore a *resume chain*: a run and
the earlier runs of the same configuration that did not finish, back to (not including) the last
one that did. "The same configuration" is the run's recorded config with its execution-only
fields (:data:`EXECUTION_FIELDS`, for example ``workers``) left out, under the same profile and
subcommand: resuming with another worker count continues the measurement.

``--run`` values (:func:`resolve_run_ids`): ``all`` (no narrowing), ``latest`` (the newest run
that stored episodes *with the runs it resumed*), one id, or comma-separated ids (taken literally).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from navbench.benchmark import LEGACY_VERSION
from navbench.errors import DatabaseError

if TYPE_CHECKING:  # pragma: no cover
    from navbench.results.db.store import ResultsDB

#: Config fields that say how a run executes, not what it measures.
EXECUTION_FIELDS = ("workers",)
#: Run statuses after which a rerun of the same configuration starts a new measurement.
FINISHED = ("done",)


def _measurement(row) -> str | None:
    """What a run measures: profile, subcommand and config without execution fields (JSON);
    ``None`` for a run recorded without a config (nothing to resume)."""
    config = row["config"]
    if isinstance(config, str):
        try:
            config = json.loads(config)
        except ValueError:
            return None
    if not isinstance(config, dict) or not config:
        return None
    config = {k: v for k, v in config.items() if k not in EXECUTION_FIELDS}
    config.setdefault("benchmark_version", LEGACY_VERSION)  # recorded before versions (issue 36)
    words = str(row["command"] or "").split()
    verb = words[1] if len(words) > 1 and words[0].endswith("navbench") else (words[0] if words else "")
    return json.dumps([row["profile"], verb, config], sort_keys=True, default=str)


def resume_chain(runs, run_id: int) -> list[int]:
    """``run_id`` and the earlier runs it resumed (module docstring), ascending; ``runs`` is
    :meth:`ResultsDB.runs_frame`."""
    rows = runs.sort_values("id")
    this = rows[rows["id"] == run_id]
    if this.empty:
        return [int(run_id)]
    key = _measurement(this.iloc[0])
    chain = [int(run_id)]
    if key is None:
        return chain
    for _, r in rows[rows["id"] < run_id].iloc[::-1].iterrows():
        if _measurement(r) != key:
            continue  # another experiment run in between
        if r["status"] in FINISHED:
            break
        chain.append(int(r["id"]))
    return sorted(chain)


def resolve_run_ids(db: "ResultsDB", run, latest: str = "episodes") -> list[int] | None:
    """The run ids ``run`` selects (module docstring); ``None`` for all. ``latest``: which run
    is the newest, the newest that stored ``"episodes"`` or the newest of ``"any"`` kind.
    A malformed value or an unknown id is a :class:`DatabaseError`."""
    if run is None or str(run) == "all":
        return None
    runs = db.runs_frame()
    if str(run) == "latest":
        if latest == "episodes":
            stored = db.episodes_frame()["run_id"]
            if stored.empty:
                raise DatabaseError(f"no episodes stored in {db.display_url}")
            newest = int(stored.max())
        else:
            if runs.empty:
                raise DatabaseError(f"no run in {db.display_url}")
            newest = int(runs["id"].max())
        return resume_chain(runs, newest)
    try:
        ids = sorted({int(v) for v in str(run).split(",")})
    except ValueError:
        raise DatabaseError(f"--run must be a run id, comma-separated run ids (a measurement "
                            f"resumed over several runs), 'latest' or 'all', not {run!r}") from None
    missing = [r for r in ids if r not in set(runs["id"])]
    if missing:
        raise DatabaseError(f"--run: no run with id {missing[0]} in {db.display_url}")
    return ids


def describe_selection(ids: list[int] | None, run) -> str | None:
    """A line saying which runs ``--run latest`` took when it took more than one."""
    if ids is None or str(run) != "latest" or len(ids) < 2:
        return None
    return (f"--run latest: runs {', '.join(map(str, ids))} (run {ids[-1]} resumed "
            f"{', '.join(map(str, ids[:-1]))}, which did not finish: one measurement)")


def resolve_selection(db: "ResultsDB", run) -> tuple[str | int | None, str | None]:
    """``run`` resolved once (``latest`` reads every episode's run id) as the literal selection
    the readers take (``"4,5,6"``; ``run`` itself for ``all`` or none) and
    :func:`describe_selection`'s line: what ``score`` and ``report`` print and pass on."""
    ids = resolve_run_ids(db, run)
    return (run if ids is None else ",".join(map(str, ids))), describe_selection(ids, run)
