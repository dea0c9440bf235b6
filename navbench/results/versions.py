"""Which benchmark version a selection of stored rows is scored under (never several at once).

Rows of two versions are not comparable (:mod:`navbench.benchmark`), so every reader of episode
rows (``score``, ``compare``, the report) passes its selection through :func:`choose_version`:
the newest version present, or the one asked for with ``--benchmark-version``, and a sentence
saying what was left out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navbench.benchmark import LEGACY_VERSION, UnknownVersion, check_version, newest, version_rank
from navbench.errors import DatabaseError

if TYPE_CHECKING:  # pragma: no cover
    import pandas

COLUMN = "benchmark_version"


def versions_of(frame: "pandas.DataFrame") -> "pandas.Series":
    """Each row's benchmark version (``navbench-1`` where the row predates the column)."""
    import pandas as pd

    if COLUMN not in frame.columns:
        return pd.Series(LEGACY_VERSION, index=frame.index, dtype=object)
    return frame[COLUMN].where(frame[COLUMN].notna(), LEGACY_VERSION).astype(object)


def _known(name: str) -> None:
    try:
        check_version(name, "--benchmark-version")
    except UnknownVersion as e:
        raise DatabaseError(str(e)) from None


def choose_version(frame: "pandas.DataFrame", requested: str | None = None,
                   what: str = "the selection") -> tuple["pandas.DataFrame", str | None, str | None]:
    """``(rows of one version, that version, a note or None)``.

    ``requested`` (``--benchmark-version``) must be a version present in ``frame`` (a version a
    newer navbench stored counts), else :class:`DatabaseError` naming the known versions or those
    present; without it the newest present is taken.
    The note says which versions were left out (``None`` when the selection held one version).
    An empty frame passes through with version ``requested``."""
    if frame.empty:
        if requested is not None:
            _known(requested)
        return frame, requested, None
    versions = versions_of(frame)
    present = sorted(set(versions), key=lambda v: (version_rank(v), v))
    chosen = requested if requested is not None else newest(present)
    if chosen not in present:
        _known(chosen)
        raise DatabaseError(f"--benchmark-version {chosen}: no rows of that version in {what} "
                            f"(versions present: {', '.join(present)})")
    kept = frame[versions == chosen].copy()
    kept[COLUMN] = chosen
    note = None
    if len(present) > 1:
        others = [v for v in present if v != chosen]
        note = (f"{what} holds rows of {len(present)} benchmark versions ({', '.join(present)}); "
                f"scoring {chosen} only ({int((versions != chosen).sum())} row(s) of "
                f"{', '.join(others)} left out; --benchmark-version selects another). "
                "Results of two versions are never pooled.")
    return kept.reset_index(drop=True), chosen, note
